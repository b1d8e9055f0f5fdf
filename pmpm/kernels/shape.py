"""Trilinear shape functions of the hexahedral cell (seed 000 Eq. 5)."""
import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _axis(x, p, d, origin, inv_h, lo, strides):
    s = (x[p, d] - origin[d]) * inv_h
    c = np.floor(s)
    return s - c, (np.int64(c) - lo[d]) * strides[d]


@njit(cache=True, inline="always")
def trilinear(x, p, origin, inv_h, lo, strides, nodes, w, gx, gy, gz):
    """Fill the 8 local node indices, weights and gradients of particle ``p``.

    Parameters
    ----------
    x : (n,3) positions; origin, inv_h: grid origin and 1/h; lo, strides: local block.
    nodes : int64 (8,) out: flat local node indices.  w, gx, gy, gz : float64 (8,) out.

    Notes
    -----
    With r the position in cell units inside its cell, the weight of corner (a,b,c) is
    prod_d (a_d ? r_d : 1 - r_d); its gradient along d replaces that factor by +-1/h.
    """
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
