"""Shape functions of the background grid: the trilinear hats of seed 000 (Eq. 5), the
uniform generalized interpolation material point functions (uGIMP, Bardenhagen and
Kober 2004) and quadratic B-splines (Steffen, Kirby and Berzins 2008).

Every shape is a tensor product of 1D functions of the particle's offset from a node
in cells. The trilinear hat reaches the 2 nodes of the particle's cell along each axis
(8 nodes); uGIMP and the quadratic B-spline reach 3 (27 nodes): the node nearest the
particle and its two neighbours. Those 3-node shapes touch one node layer beyond the
particle's cell, so a rank's node block carries a halo of ``HALO[kind]`` node layers
(``pmpm.grid.LocalBlock``).

uGIMP convolves the hat with the particle's characteristic function of half-width
``lp`` (in cells; ``0.5 / particles_per_cell`` of the body): with r the offset,

    |r| <  lp:            1 - (r^2 + lp^2) / (2 lp)
    lp <= |r| <= 1 - lp:  1 - |r|
    1 - lp < |r| < 1 + lp: (1 + lp - |r|)^2 / (4 lp)

Both it and the B-spline have continuous gradients, so a particle crossing a cell face
no longer sees its stress-divergence weights jump (the cell-crossing error of the hat).
"""
import math

import numpy as np
from numba import njit

LINEAR, GIMP, BSPLINE = 0, 1, 2
#: case-file name (``grid.shape_functions``) -> code
SHAPE_CODES = {"linear": LINEAR, "gimp": GIMP, "bspline": BSPLINE}
#: node layers a shape reaches beyond the particle's cell
HALO = {LINEAR: 0, GIMP: 1, BSPLINE: 1}
#: the most nodes any shape reaches (the size of the kernels' per-particle scratch)
MAX_NODES = 27
#: what a GridGeometry carries for each shape: a tuple whose *length* is the code. The
#: length is part of the tuple's Numba type, so every kernel is compiled once per shape
#: with the code a constant: LLVM drops the other shapes' branches and unrolls the hat's
#: 8-node loops (a runtime code ran the hat at half its former speed).
MARKERS = {LINEAR: (), GIMP: (0,), BSPLINE: (0, 0)}


@njit(cache=True, inline="always")
def axis_stencil(s, kind, lp, axes, row):
    """The 1D weights ``axes[row]``, derivatives in cells ``axes[row + 1]`` and offsets
    from the node ``axes[row + 2]`` (particle minus node, in cells) of the nodes a
    particle at ``s`` (cells from the origin) reaches along one axis; returns (first node
    index, node count)."""
    if kind == LINEAR:
        c = np.floor(s)
        r = s - c
        axes[row, 0], axes[row, 1] = 1.0 - r, r
        axes[row + 1, 0], axes[row + 1, 1] = -1.0, 1.0
        axes[row + 2, 0], axes[row + 2, 1] = r, r - 1.0
        return np.int64(c), 2
    c = np.floor(s + 0.5)
    d = s - c                                    # in [-0.5, 0.5)
    axes[row + 2, 0], axes[row + 2, 1], axes[row + 2, 2] = d + 1.0, d, d - 1.0
    if kind == BSPLINE:
        axes[row, 0] = 0.5 * (0.5 - d) ** 2
        axes[row, 1] = 0.75 - d * d
        axes[row, 2] = 0.5 * (0.5 + d) ** 2
        axes[row + 1, 0], axes[row + 1, 1], axes[row + 1, 2] = d - 0.5, -2.0 * d, 0.5 + d
    else:
        axes[row, 0], axes[row, 1], axes[row, 2] = _gimp_three(d, lp)
        axes[row + 1, 0], axes[row + 1, 1], axes[row + 1, 2] = _gimp_three_slopes(d, lp)
    return np.int64(c) - 1, 3


@njit(cache=True, inline="always")
def axis_weights(s, kind, lp, axes, row):
    """:func:`axis_stencil` without the derivatives (``axes[row + 1]`` is left as it
    was): the particle-to-grid and grid-to-particle passes need only the weights."""
    if kind == LINEAR:
        c = np.floor(s)
        r = s - c
        axes[row, 0], axes[row, 1] = 1.0 - r, r
        axes[row + 2, 0], axes[row + 2, 1] = r, r - 1.0
        return np.int64(c), 2
    c = np.floor(s + 0.5)
    d = s - c
    axes[row + 2, 0], axes[row + 2, 1], axes[row + 2, 2] = d + 1.0, d, d - 1.0
    if kind == BSPLINE:
        axes[row, 0] = 0.5 * (0.5 - d) ** 2
        axes[row, 1] = 0.75 - d * d
        axes[row, 2] = 0.5 * (0.5 + d) ** 2
    else:
        axes[row, 0], axes[row, 1], axes[row, 2] = _gimp_three(d, lp)
    return np.int64(c) - 1, 3


@njit(cache=True, inline="always")
def _gimp(r, lp):
    """uGIMP weight and its derivative along the offset ``r`` (cells), half-width lp: the
    hat averaged over [r - lp, r + lp], written with the hat's running integral
    :func:`_hat_integral` so that it has no branches (a particle's three nodes fall in
    different pieces, and branching on them cost twice the B-spline's time per step)."""
    inv_width = 0.5 / lp
    weight = (_hat_integral(r + lp) - _hat_integral(r - lp)) * inv_width
    slope = (max(0.0, 1.0 - abs(r + lp)) - max(0.0, 1.0 - abs(r - lp))) * inv_width
    return weight, slope


@njit(cache=True, inline="always")
def _gimp_three(d, lp):
    """uGIMP's three weights of a particle ``d`` cells from its nearest node (d in
    [-0.5, 0.5)), for lp <= 0.5. Then the particle's support lies on the near side of
    each outer node, inside its hat, so each outer weight has two pieces of the depth t
    of the support past the node's half-way line (:func:`_gimp_outer`) and the middle
    node takes what they leave: the three sum to one by construction, for a third of
    the work of three :func:`_gimp` calls. Scalars in and out: an inlined helper handed
    the scratch array would cost a reference count on it per call (twice the
    transfers' time)."""
    if lp > 0.5:                 # wider than a cell: each node's weight on its own
        return _gimp(d + 1.0, lp)[0], _gimp(d, lp)[0], _gimp(d - 1.0, lp)[0]
    inv_4lp, width = 0.25 / lp, 2.0 * lp
    w0 = _gimp_outer(max(lp - d, 0.0), width, inv_4lp)
    w2 = _gimp_outer(max(lp + d, 0.0), width, inv_4lp)
    return w0, 1.0 - w0 - w2, w2


@njit(cache=True, inline="always")
def _gimp_outer(t, width, inv_4lp):
    """An outer node's uGIMP weight, t the particle's support (of ``width`` = 2 lp)
    past the line half-way to the middle node, t >= 0: the hat's tip piece
    t^2 / (4 lp) while the support straddles the node's hat edge (t < 2 lp), then
    t - lp, where the whole support lies on the hat's slope (u = min(t, 2 lp): both
    in one expression, no branch)."""
    u = min(t, width)
    return u * u * inv_4lp + (t - u)


@njit(cache=True, inline="always")
def _gimp_three_slopes(d, lp):
    """The derivatives along the offset of :func:`_gimp_three`'s weights (they sum to
    zero by construction): -+ min(t, 2 lp) / (2 lp) for the outer nodes."""
    if lp > 0.5:
        return _gimp(d + 1.0, lp)[1], _gimp(d, lp)[1], _gimp(d - 1.0, lp)[1]
    inv_2lp, width = 0.5 / lp, 2.0 * lp
    s0 = -min(max(lp - d, 0.0), width) * inv_2lp
    s2 = min(max(lp + d, 0.0), width) * inv_2lp
    return s0, -(s0 + s2), s2


@njit(cache=True, inline="always")
def _hat_integral(s):
    """The integral of the hat max(0, 1 - |t|) over t from -infinity to s."""
    c = min(abs(s), 1.0)
    return 0.5 + math.copysign(c - 0.5 * c * c, s)


@njit(cache=True, inline="always")
def point_axes(x, p, origin, inv_h, lo, strides, kind, lp, axes):
    """Fill ``axes`` (9, 3) with particle p's 1D weights, derivatives (in cells) and
    offsets along each axis d in rows 3d..3d+2 (:func:`axis_stencil`); returns (flat local
    index of the first node it reaches, nodes per axis)."""
    base, count = 0, 2
    for d in range(3):
        first, count = axis_stencil((x[p, d] - origin[d]) * inv_h, kind, lp, axes, 3 * d)
        base += (first - lo[d]) * strides[d]
    return base, count


@njit(cache=True, forceinline=True)
def stencil(x, p, origin, inv_h, lo, strides, kind, lp, axes, nodes, w, gx, gy, gz):
    """Fill the local node indices, weights and gradients of particle ``p``; returns how
    many nodes it reaches (8 or 27).

    Parameters
    ----------
    x : (n,3) positions; origin, inv_h: grid origin and 1/h; lo, strides: local block.
    kind, lp : shape code and the particle's uGIMP half-width in cells.
    axes : float64 (9, 3) scratch: per axis d, rows 3d..3d+2 hold weights, derivatives
        and offsets (see :func:`axis_stencil`).
    nodes : int64 (27,) out: flat local node indices.  w, gx, gy, gz : float64 (27,) out.

    Notes
    -----
    The weight of node (a,b,c) is prod_d W_d; its gradient along d replaces W_d by its
    derivative times 1/h. For the hat this is seed 000's trilinear function exactly.
    Speed: the hat takes its own unrolled path (8 nodes, as before the 27-node shapes);
    the scratch is indexed, never sliced, since every slice costs a reference count.
    Compiled once and inlined by LLVM (``forceinline``), so that the kernels do not type
    it again each; ``kind`` is a constant in every kernel, so LLVM drops the other
    shapes' paths after inlining. Its own helpers stay inlined at Numba IR level: made
    ``forceinline`` too, they cost the gimp step about 15 %.
    """
    if kind == LINEAR:
        _trilinear(x, p, origin, inv_h, lo, strides, nodes, w, gx, gy, gz)
        return 8
    base, count = point_axes(x, p, origin, inv_h, lo, strides, kind, lp, axes)
    for d in range(3):
        for j in range(count):
            axes[3 * d + 1, j] *= inv_h
    k = 0
    for a in range(count):
        for b in range(count):
            for c in range(count):
                nodes[k] = base + a * strides[0] + b * strides[1] + c * strides[2]
                w[k] = axes[0, a] * axes[3, b] * axes[6, c]
                gx[k] = axes[1, a] * axes[3, b] * axes[6, c]
                gy[k] = axes[0, a] * axes[4, b] * axes[6, c]
                gz[k] = axes[0, a] * axes[3, b] * axes[7, c]
                k += 1
    return k


@njit(cache=True, inline="always")
def point_weights(x, p, origin, inv_h, lo, strides, kind, lp, axes):
    """:func:`point_axes` without the derivatives: ``axes``' rows 3d and 3d + 2 (the 1D
    weights and offsets along axis d); returns (flat local index of the first node,
    nodes per axis)."""
    base, count = 0, 3
    for d in range(3):
        first, count = axis_weights((x[p, d] - origin[d]) * inv_h, kind, lp, axes, 3 * d)
        base += (first - lo[d]) * strides[d]
    return base, count


@njit(cache=True, forceinline=True)
def weights(x, p, origin, inv_h, lo, strides, kind, lp, axes, nodes, w):
    """:func:`stencil` without the gradients: the local node indices and weights of
    particle ``p`` (and the offsets of ``axes``' rows 3d + 2, which APIC reads); returns
    how many nodes it reaches. The transfers (particles to grid and back) read no
    gradient, and with the 27-node shapes computing them cost about a third of those
    passes."""
    if kind == LINEAR:
        r0, b0 = _axis(x, p, 0, origin, inv_h, lo, strides)
        r1, b1 = _axis(x, p, 1, origin, inv_h, lo, strides)
        r2, b2 = _axis(x, p, 2, origin, inv_h, lo, strides)
        base = b0 + b1 + b2
        k = 0
        for a in range(2):
            wx = r0 if a else 1.0 - r0
            for b in range(2):
                wy = r1 if b else 1.0 - r1
                for c in range(2):
                    nodes[k] = base + a * strides[0] + b * strides[1] + c * strides[2]
                    w[k] = wx * wy * (r2 if c else 1.0 - r2)
                    k += 1
        return 8
    base, count = point_weights(x, p, origin, inv_h, lo, strides, kind, lp, axes)
    k = 0
    for a in range(count):
        for b in range(count):
            wab = axes[0, a] * axes[3, b]
            row = base + a * strides[0] + b * strides[1]
            for c in range(count):
                nodes[k] = row + c * strides[2]
                w[k] = wab * axes[6, c]
                k += 1
    return k


@njit(cache=True, inline="always")
def _axis(x, p, d, origin, inv_h, lo, strides):
    s = (x[p, d] - origin[d]) * inv_h
    c = np.floor(s)
    return s - c, (np.int64(c) - lo[d]) * strides[d]


@njit(cache=True, inline="always")
def _trilinear(x, p, origin, inv_h, lo, strides, nodes, w, gx, gy, gz):
    """The 8 trilinear weights and gradients of particle ``p`` (seed 000 Eq. 5): with r
    the position in cell units inside its cell, the weight of corner (a,b,c) is
    prod_d (a_d ? r_d : 1 - r_d); its gradient along d replaces that factor by +-1/h."""
    r0, b0 = _axis(x, p, 0, origin, inv_h, lo, strides)
    r1, b1 = _axis(x, p, 1, origin, inv_h, lo, strides)
    r2, b2 = _axis(x, p, 2, origin, inv_h, lo, strides)
    base = b0 + b1 + b2
    k = 0
    for a in range(2):
        wx = r0 if a else 1.0 - r0
        dx = inv_h if a else -inv_h
        for b in range(2):
            wy = r1 if b else 1.0 - r1
            dy = inv_h if b else -inv_h
            for c in range(2):
                wz = r2 if c else 1.0 - r2
                dz = inv_h if c else -inv_h
                nodes[k] = base + a * strides[0] + b * strides[1] + c * strides[2]
                w[k] = wx * wy * wz
                gx[k] = dx * wy * wz
                gy[k] = wx * dy * wz
                gz[k] = wx * wy * dz
                k += 1
