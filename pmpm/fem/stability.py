"""The stable time step of one hexahedron (Numba): an upper bound of its largest
eigenfrequency, hourglass stiffness and damping included, so that the element's step
``dt = cfl / rate`` keeps the central-difference update stable at cfl 1 (issue 27).

With lumped masses ``M = rho V / 8`` at each node, the assembled mesh's largest
eigenfrequency is at most the largest of its elements' (Irons), so bounding each
element's suffices. For the one-point element with the mean gradients ``b_I`` and the
hourglass shape vectors ``gamma_a`` (:mod:`pmpm.fem.hexahedron`):

* mean strain: ``u.K u = V (lambda tr(eps)^2 + 2 mu eps:eps)`` with
  ``eps = sym(sum_I u_I (x) b_I) / V``, so ``tr(eps)^2 <= |u|^2 S / V^2`` (``S`` the sum
  of ``|b_I|^2``) and ``eps:eps <= |u|^2 beta / V^2`` (``beta`` the largest eigenvalue of
  ``sum_I b_I b_I^T``, bounded by its largest absolute row sum), hence
  ``omega^2 <= 8 (lambda S + 2 mu beta) / (rho V^2)``; exact for a cube;
  ``lambda = rho c^2 - 2 G`` (``rho c^2 = K_t + 4G/3``, G the material's shear modulus),
  taken as 0 where negative;
* the stiffness hourglass form ``Q_a = k rho c^2 S / (3V) sum_I u_I gamma_aI`` adds
  ``omega^2 <= 8 k c^2 S g / (3 V^2)`` with ``g`` the largest absolute row sum of the Gram
  matrix ``gamma_a . gamma_b`` (8 on a parallelepiped);
* the assumed-strain element's hourglass stiffness (:mod:`pmpm.fem.assumed_strain`,
  ``Q = K q`` with ``q_ai = gamma_a . u_i / 8``) adds ``omega^2 <= kappa g / (8 rho V)``,
  kappa a bound of K's largest eigenvalue;
* damping, the viscous forces of the half-step velocity (bulk viscosity
  ``q = rho L (C0 L |div| + C1 c) |div|`` and the viscous hourglass form
  ``Q_a = k rho c V^(2/3) / 4 q_a``), rate ``eta`` = largest eigenvalue of ``M^-1 C``:
  ``8 L (C1 c + C0 L |div|) S / V^2 + 2 k c g / V^(1/3)``.

The update ``v += dt M^-1 (-K u - C v)``, ``u += dt v`` of a mode is stable for
``omega^2 dt^2 + 2 eta dt <= 4``, that is ``1 / dt >= (eta / 2 + sqrt(omega^2 + eta^2 / 4))
/ 2``: the rate returned. Without damping it is ``omega / 2``; on a cube of edge h,
Poisson's ratio 0.3, ``1.36 c / h`` where ``c / L_e`` (the step before issue 27) gave
``c / h``: that step was 36 % too long before any hourglass stiffness was added.
"""
import numpy as np
from numba import njit

from ..materials.layout import G, Q_LINEAR, Q_QUADRATIC
from ..materials.tensors import fdiv
from .assumed_strain import assumed_strain_omega2, element_frame, plate_moduli
from .hexahedron import hourglass_shapes, largest_face_area, mean_gradient

#: hourglass forms (as :mod:`pmpm.fem.elements`); ASSUMED_STRAIN: the physical
#: hourglass stiffness of the ``assumed_strain`` element (:mod:`pmpm.fem.assumed_strain`)
VISCOUS, STIFFNESS, ASSUMED_STRAIN = 0, 1, 2


@njit(cache=True, inline="always")
def gradient_sums(b):
    """(S, beta): the sum of |b_I|^2 and a bound of the largest eigenvalue of
    sum_I b_I b_I^T (its largest absolute row sum)."""
    xx = yy = zz = xy = yz = zx = 0.0
    for k in range(8):
        bx, by, bz = b[k, 0], b[k, 1], b[k, 2]
        xx += bx * bx
        yy += by * by
        zz += bz * bz
        xy += bx * by
        yz += by * bz
        zx += bz * bx
    beta = max(xx + abs(xy) + abs(zx), max(yy + abs(xy) + abs(yz), zz + abs(yz) + abs(zx)))
    return xx + yy + zz, beta


@njit(cache=True, inline="always")
def hourglass_gram_bound(gamma):
    """The largest absolute row sum of the Gram matrix gamma_a . gamma_b (4 x 4); its
    ten distinct entries computed once (a product commutes exactly, so the matrix is
    symmetric to the bit), each row summed in column order."""
    g00, g01, g02, g03 = _dot8(gamma, 0, 0), _dot8(gamma, 0, 1), _dot8(gamma, 0, 2), \
        _dot8(gamma, 0, 3)
    g11, g12, g13 = _dot8(gamma, 1, 1), _dot8(gamma, 1, 2), _dot8(gamma, 1, 3)
    g22, g23, g33 = _dot8(gamma, 2, 2), _dot8(gamma, 2, 3), _dot8(gamma, 3, 3)
    return gram_row_bound(g00, g01, g02, g03, g11, g12, g13, g22, g23, g33)


@njit(cache=True, inline="always")
def gram_row_bound(g00, g01, g02, g03, g11, g12, g13, g22, g23, g33):
    """The largest absolute row sum of the symmetric 4 x 4 Gram matrix from its ten
    distinct entries, each row summed in column order (pmpm.fem.lanes calls it per
    lane, so both give the same bits)."""
    r0 = abs(g00) + abs(g01) + abs(g02) + abs(g03)
    r1 = abs(g01) + abs(g11) + abs(g12) + abs(g13)
    r2 = abs(g02) + abs(g12) + abs(g22) + abs(g23)
    r3 = abs(g03) + abs(g13) + abs(g23) + abs(g33)
    return max(max(max(max(0.0, r0), r1), r2), r3)


@njit(cache=True, inline="always")
def _dot8(gamma, a, c):
    """gamma_a . gamma_c, summed over the nodes in order."""
    s = 0.0
    for k in range(8):
        s += gamma[a, k] * gamma[c, k]
    return s


@njit(cache=True, inline="always")
def stable_rate(b, gamma, volume, length, rho, c, prm, hg_kind, hg_k, div, half):
    """1 / (the element's stable step at cfl 1): see the module's docstring.

    b, gamma : the element's mean gradients (8, 3) and hourglass shapes (4, 8)
    volume, length : V and the bulk viscosity's length L
    rho, c : current density and wave speed (the material update's)
    prm : the body's packed material row (shear modulus, bulk viscosity coefficients)
    hg_kind, hg_k : hourglass form and coefficient
    div : the volumetric strain rate of the step
    half : the half-lengths of pmpm.fem.assumed_strain.element_frame (read for
        ASSUMED_STRAIN only)
    """
    s, beta = gradient_sums(b)
    g = hourglass_gram_bound(gamma)
    inv_v2 = fdiv(1.0, volume * volume)
    shear = prm[G]
    lam = max(rho * c * c - 2.0 * shear, 0.0)
    omega2 = 8.0 * (lam * s + 2.0 * shear * beta) * inv_v2 * fdiv(1.0, rho)
    eta = 8.0 * length * (prm[Q_LINEAR] * c + prm[Q_QUADRATIC] * length * abs(div)) \
        * s * inv_v2
    if hg_kind == STIFFNESS:
        omega2 += 8.0 * hg_k * c * c * s * g * inv_v2 / 3.0
    elif hg_kind == ASSUMED_STRAIN:
        omega2 += assumed_strain_omega2(half, volume, rho, plate_moduli(rho, c, shear, 1.0), g)
    else:
        eta += 2.0 * hg_k * c * g * fdiv(1.0, np.cbrt(volume))
    return 0.5 * (0.5 * eta + np.sqrt(omega2 + 0.25 * eta * eta))


@njit(cache=True)
def element_rates(x, hexes, body, rho, c, params, hg_kind, hg_k, out):
    """Per element of ``hexes`` its stable_rate at rest (div = 0) with the per-body density
    ``rho``, wave speed ``c``, material rows ``params`` and hourglass forms, into ``out``
    (0 where the body has no wave speed, inf where the element is inverted). With the
    materials' initial density and speed it depends on the element's shape only: the
    set-up's first step and a rule on collapsing elements (FemBodies.shape_rates)
    read it; the step's own rate comes from element_forces."""
    xe, b, gamma = np.empty((8, 3)), np.empty((8, 3)), np.empty((4, 8))
    frame, half = np.empty((3, 3)), np.ones(3)
    for e in range(hexes.shape[0]):
        bb = body[e]
        out[e] = 0.0
        if c[bb] <= 0.0:
            continue
        for k in range(8):
            for i in range(3):
                xe[k, i] = x[hexes[e, k], i]
        volume = mean_gradient(xe, b)
        if not volume > 0.0:
            out[e] = np.inf
            continue
        hourglass_shapes(xe, b, 1.0 / volume, gamma)
        if hg_kind[bb] == ASSUMED_STRAIN:
            element_frame(xe, frame, half)
        length = volume / largest_face_area(xe)
        out[e] = stable_rate(b, gamma, volume, length, rho[bb], c[bb], params[bb],
                             hg_kind[bb], hg_k[bb], 0.0, half)


@njit(cache=True)
def mesh_rate(x, hexes, body, rho, c, params, hg_kind, hg_k):
    """The largest stable_rate over the elements of ``hexes`` at rest that are not
    inverted (element_rates; for the set-up's first step and the tests)."""
    out = np.empty(hexes.shape[0])
    element_rates(x, hexes, body, rho, c, params, hg_kind, hg_k, out)
    largest = 0.0
    for e in range(out.shape[0]):
        if out[e] < np.inf:
            largest = max(largest, out[e])
    return largest
