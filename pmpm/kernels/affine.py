"""The affine particle-in-cell transfer (APIC, Jiang et al. 2015), generalised to any
27-node tensor-product shape: the per-particle pieces the scatter and gather loops use.

A particle carries, besides its velocity v_p, the affine matrix B_p = sum_i w_ip v_i
(x_i - x_p)^T of its last gather. Its scatter puts the momentum m_p w_ip (v_p + B_p
D_p^{-1} (x_i - x_p)) on node i, with D_p = sum_i w_ip (x_i - x_p)(x_i - x_p)^T at the
particle's present position. Both transfers then keep the angular momentum
sum_p (x_p x m_p v_p + m_p eps : B_p^T) exactly, and the gather takes the grid's velocity
(PIC) without its dissipation.

Units: offsets in cells of the particle's grid level, e_i = (x_i - x_p)/h. The column
``affine`` stores A_p = B_p / h^2 (1/ms), so that B_p D_p^{-1} = A_p E_p^{-1} with
E_p = D_p / h^2 (cells^2) and the affine velocity at node i is h A_p E_p^{-1} e_i: a
particle that changes level (a window) or splits keeps its velocity gradient B D^{-1}
(exactly for the B-spline, whose E is I/4 on every level). The 8-node hat has
E_p singular at the nodes and is not served (the case check refuses it).
"""
import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def node_offsets(axes, e):
    """e[k] = (x_i - x_p)/h of the k-th of the 27 stencil nodes (the order of
    :func:`pmpm.kernels.shape.stencil`), from the offsets rows of ``axes``."""
    k = 0
    for a in range(3):
        for b in range(3):
            for c in range(3):
                e[k, 0], e[k, 1], e[k, 2] = -axes[2, a], -axes[5, b], -axes[8, c]
                k += 1


@njit(cache=True, inline="always")
def _moments(axes, row):
    """The 0th, 1st and 2nd moments sum_j w_j e_j^k of one axis's weights (rows ``row``:
    weights, ``row + 2``: offsets particle minus node, so e_j is minus it)."""
    m0 = m1 = m2 = 0.0
    for j in range(3):
        wj, ej = axes[row, j], -axes[row + 2, j]
        m0 += wj
        m1 += wj * ej
        m2 += wj * ej * ej
    return m0, m1, m2


@njit(cache=True, inline="always")
def affine_velocity_matrix(affine, p, axes, h, out):
    """out = h A_p E_p^{-1}: the node velocity increment per cell of offset. E_p is built
    from the 1D moments of the weights (tensor product): E_dd = m2_d m0_f m0_g and
    E_de = m1_d m1_e m0_f (the first moments vanish where the shape reproduces linear
    functions, so E is then diagonal)."""
    x0, x1, x2 = _moments(axes, 0)     # scalars: no array per particle
    y0, y1, y2 = _moments(axes, 3)
    z0, z1, z2 = _moments(axes, 6)
    e00, e11, e22 = x2 * y0 * z0, y2 * x0 * z0, z2 * x0 * y0
    e01, e12, e02 = x1 * y1 * z0, y1 * z1 * x0, x1 * z1 * y0
    c00, c11, c22 = e11 * e22 - e12 * e12, e00 * e22 - e02 * e02, e00 * e11 - e01 * e01
    c01, c02, c12 = e02 * e12 - e01 * e22, e01 * e12 - e02 * e11, e01 * e02 - e00 * e12
    scale = h / (e00 * c00 + e01 * c01 + e02 * c02)      # h / det E
    for r in range(3):
        a0, a1, a2 = affine[p, 3 * r], affine[p, 3 * r + 1], affine[p, 3 * r + 2]
        out[r, 0] = scale * (a0 * c00 + a1 * c01 + a2 * c02)
        out[r, 1] = scale * (a0 * c01 + a1 * c11 + a2 * c12)
        out[r, 2] = scale * (a0 * c02 + a1 * c12 + a2 * c22)
