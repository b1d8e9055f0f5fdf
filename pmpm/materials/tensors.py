"""Symmetric second-order tensors as Voigt 6-tuples, for the per-particle material kernels.

A symmetric tensor is a tuple ``(t_xx, t_yy, t_zz, t_xy, t_yz, t_zx)`` of float64 with
*tensor* (not engineering) shear components, the storage order of ``stress`` (see
docs/CONTRACTS.md). Tuples live in registers, so these helpers allocate nothing, which
keeps the per-particle path of the fused stress kernel free of heap traffic. Every helper
is compiled once and marked for LLVM to inline it into its caller (``forceinline=True``,
LLVM's ``alwaysinline``): a 6-tuple passed to or returned from a call that stays a call
goes through memory, an inlined one stays in registers. (Numba's IR-level
``inline="always"`` gives the same code but types the body again at every call site of
every kernel specialisation, which made the cold compile slow.)
"""
import math

import numpy as np
from numba import njit


@njit(cache=True, forceinline=True)
def fdiv(a, b):
    """IEEE quotient ``a / b`` of two floats: inf or NaN for ``b == 0``, never an exception.

    Notes
    -----
    Under Numba's default (Python) error model ``/`` tests the divisor and raises
    ZeroDivisionError. Such raise paths inside a loop keep Numba's reference counting of
    the arrays live across them (two atomic operations per array and iteration) in the
    compiled loop, e.g. the fused particle loop that inlines the stress update. Every
    division of the per-particle path uses this instead; a zero divisor then gives a
    non-finite result, which :func:`pmpm.materials.kernels.update_stress` reports as a
    failed update. Same rounding as ``/``.
    """
    return np.divide(a, b)


@njit(cache=True, forceinline=True)
def strain_rate(Lg):
    """Rate of deformation D = sym(Lg) as a Voigt 6-tuple.

    Parameters
    ----------
    Lg : float64[3, 3]
        Velocity gradient, ``Lg[i, j] = dv_i/dx_j``.

    Returns
    -------
    tuple of 6 float
        ``(D_xx, D_yy, D_zz, D_xy, D_yz, D_zx)``, tensor shear components.
    """
    return (Lg[0, 0], Lg[1, 1], Lg[2, 2],
            0.5 * (Lg[0, 1] + Lg[1, 0]),
            0.5 * (Lg[1, 2] + Lg[2, 1]),
            0.5 * (Lg[2, 0] + Lg[0, 2]))


@njit(cache=True, forceinline=True)
def spin(Lg):
    """Independent components of the spin W = skew(Lg).

    Returns
    -------
    tuple of 3 float
        ``(W_xy, W_yz, W_zx)`` with ``W_ij = (Lg[i, j] - Lg[j, i]) / 2``; the other
        off-diagonal entries follow from antisymmetry.
    """
    return (0.5 * (Lg[0, 1] - Lg[1, 0]),
            0.5 * (Lg[1, 2] - Lg[2, 1]),
            0.5 * (Lg[2, 0] - Lg[0, 2]))


@njit(cache=True, forceinline=True)
def sym9(l):
    """:func:`strain_rate` of a velocity gradient given as a row-major 9-tuple."""
    return (l[0], l[4], l[8],
            0.5 * (l[1] + l[3]),
            0.5 * (l[5] + l[7]),
            0.5 * (l[6] + l[2]))


@njit(cache=True, forceinline=True)
def skew9(l):
    """:func:`spin` of a velocity gradient given as a row-major 9-tuple."""
    return (0.5 * (l[1] - l[3]),
            0.5 * (l[5] - l[7]),
            0.5 * (l[6] - l[2]))


@njit(cache=True, forceinline=True)
def trace(t):
    """Trace of a Voigt 6-tuple."""
    return t[0] + t[1] + t[2]


@njit(cache=True, forceinline=True)
def deviator(t):
    """Deviatoric part ``t - tr(t)/3 I`` of a Voigt 6-tuple."""
    m = (t[0] + t[1] + t[2]) / 3.0
    return (t[0] - m, t[1] - m, t[2] - m, t[3], t[4], t[5])


@njit(cache=True, forceinline=True)
def scale(t, a):
    """``a * t`` for a Voigt 6-tuple ``t`` and a scalar ``a``."""
    return (a * t[0], a * t[1], a * t[2], a * t[3], a * t[4], a * t[5])


@njit(cache=True, forceinline=True)
def add(a, b):
    """Sum of two Voigt 6-tuples."""
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3], a[4] + b[4], a[5] + b[5])


@njit(cache=True, forceinline=True)
def double_dot(a, b):
    """Full contraction ``a : b = a_ij b_ij`` of two symmetric tensors.

    Notes
    -----
    Each shear component appears twice in the full tensor, hence the factor 2.
    """
    return (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
            + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]))


@njit(cache=True, forceinline=True)
def von_mises(s):
    """Von Mises equivalent stress ``sqrt(3/2 s:s)`` of a deviator ``s``."""
    return math.sqrt(1.5 * double_dot(s, s))


@njit(cache=True, forceinline=True)
def all_finite(t):
    """True when every component of a Voigt 6-tuple is finite."""
    return (math.isfinite(t[0]) and math.isfinite(t[1]) and math.isfinite(t[2])
            and math.isfinite(t[3]) and math.isfinite(t[4]) and math.isfinite(t[5]))


@njit(cache=True, forceinline=True)
def jaumann_rotate(sig, w, dt):
    """Rotate a stress with the spin over one step: ``sig + (W sig - sig W) dt``.

    Parameters
    ----------
    sig : tuple of 6 float
        Stress (Voigt order xx, yy, zz, xy, yz, zx).
    w : tuple of 3 float
        Spin components ``(W_xy, W_yz, W_zx)`` from :func:`spin`.
    dt : float
        Time step.

    Returns
    -------
    tuple of 6 float
        The rotated stress.

    Notes
    -----
    This is the forward-Euler integration of the co-rotational part of the Jaumann rate
    (``W sig - sig W``). With ``M = W sig``, and W antisymmetric, sig symmetric,
    ``W sig - sig W = M + M^T``, written out component by component below. The rotation
    preserves the trace exactly; the other invariants drift by a relative
    ``O((|W| dt)^2)`` per step, e.g. ``exp(2 theta^2 / N) - 1`` for a rotation through
    ``theta`` in ``N`` equal steps.
    """
    wxy, wyz, wzx = w
    sxx, syy, szz, sxy, syz, szx = sig
    rxx = 2.0 * (wxy * sxy - wzx * szx)
    ryy = 2.0 * (wyz * syz - wxy * sxy)
    rzz = 2.0 * (wzx * szx - wyz * syz)
    rxy = wxy * (syy - sxx) - wzx * syz + wyz * szx
    ryz = wyz * (szz - syy) - wxy * szx + wzx * sxy
    rzx = wzx * (sxx - szz) - wyz * sxy + wxy * syz
    return (sxx + rxx * dt, syy + ryy * dt, szz + rzz * dt,
            sxy + rxy * dt, syz + ryz * dt, szx + rzx * dt)


@njit(cache=True, forceinline=True)
def load_row6(a, p):
    """Row ``p`` of an (n, 6) array as a 6-tuple."""
    return (a[p, 0], a[p, 1], a[p, 2], a[p, 3], a[p, 4], a[p, 5])


@njit(cache=True, forceinline=True)
def store_stress(stress, p, s, pressure):
    """Write ``s - pressure I`` (deviator ``s``, pressure positive in compression) to row p."""
    stress[p, 0] = s[0] - pressure
    stress[p, 1] = s[1] - pressure
    stress[p, 2] = s[2] - pressure
    stress[p, 3] = s[3]
    stress[p, 4] = s[4]
    stress[p, 5] = s[5]


@njit(cache=True, forceinline=True)
def determinant9(f):
    """det F for a row-major 9-tuple."""
    return (f[0] * (f[4] * f[8] - f[5] * f[7]) - f[1] * (f[3] * f[8] - f[5] * f[6])
            + f[2] * (f[3] * f[7] - f[4] * f[6]))


@njit(cache=True, forceinline=True)
def left_cauchy_green(f):
    """B = F F^T of a row-major 9-tuple, as Voigt (xx, yy, zz, xy, yz, zx)."""
    return (f[0] * f[0] + f[1] * f[1] + f[2] * f[2],
            f[3] * f[3] + f[4] * f[4] + f[5] * f[5],
            f[6] * f[6] + f[7] * f[7] + f[8] * f[8],
            f[0] * f[3] + f[1] * f[4] + f[2] * f[5],
            f[3] * f[6] + f[4] * f[7] + f[5] * f[8],
            f[6] * f[0] + f[7] * f[1] + f[8] * f[2])
