"""Physical hourglass stiffness of the one-point hexahedron that bends right (Numba; the
``assumed_strain`` element of a case's ``fem.element``, issue 24).

The one-point element (:mod:`pmpm.fem.elements`) takes the mean strain of the element;
what it leaves out are the four hourglass modes h_a = (eta zeta, xi zeta, xi eta,
xi eta zeta) of each displacement component. The reduced element resists them with
an arbitrary stiffness scaled by the sum of |b_I|^2, which a thin direction dominates, so
a plate or beam with one or two elements through its thickness is many times too stiff
(or, with a small coefficient, too soft) in bending. Here their stiffness is the strain
energy of an assumed strain field of the modes, in the style of Belytschko and
Bindeman's assumed-strain stabilisation (1993), derived for this code as follows.

In the element's corotational frame (axes e_k along the centre Jacobian's columns
``g_k = sum_I xi_kI x_I / 8``, orthonormalised; half-lengths ``l_k = |g_k|``) a
component u_i = q_ai h_a has, on a rectangular element, the strain of
d h_a / d xi_k / l_k. Its energy over the element, with the incompatible modes
u_i = (1 - xi_k^2) of Wilson and Taylor's hexahedron condensed out (they decouple from
the rest by symmetry), falls into independent blocks (W = V / 3):

* bending of the fibres along i and j across the thickness k (u_i = xi_i xi_k, mode
  missing j; u_j = xi_j xi_k, mode missing i): the parasitic shear the trilinear field
  brings with it is what the incompatible modes remove, and the thickness stress they
  free leaves the plate modulus, ``W [[D1/l_i^2, D2/(l_i l_j)], [D2/(l_i l_j), D1/l_j^2]]``
  with ``D1 = E/(1-nu^2) = 4 mu (lam+mu)/(lam+2mu)``, ``D2 = nu D1 = 2 mu lam/(lam+2mu)``.
  Pure bending of a rectangular element is then exact for any nu, and a beam whose
  section is free to contract (the fibre across, j, left free) takes E;
* twist (u_x = eta zeta, u_y = xi zeta, u_z = xi eta): shear strains only, exact,
  the stiffness ``mu W B^T B`` with ``B t = (t0/l1 + t1/l0, t0/l2 + t2/l0,
  t1/l2 + t2/l1)`` the three shear strains' amplitudes;
* the xi eta zeta mode of u_i: ``(W / 3) ((lam + 2 mu)/l_i^2 + mu/l_j^2 + mu/l_k^2)``.

The generalized coordinates are ``q_ai = gamma_a . u_i / 8`` (gamma_a the
Flanagan-Belytschko hourglass shapes, with gamma_a . h_b = 8 delta_ab on a
parallelepiped; gamma is orthogonal to every linear field, so the patch test and rigid
motions give no hourglass force on any hexahedron). Their rates in the local frame
update the generalized forces ``Q_ai += dt K q'_ai``, kept in the local frame (so they
turn with the element), and the nodes take ``f_I = -sum_a gamma_aI R Q_a / 8``. The
moduli are the material's elastic ones at the step (``rho c^2 = lam + 2 mu``, mu its
shear modulus), except that in a step where the element yields mu is scaled by the
elastic share of the step's deviatoric strain increment (:func:`elastic_fraction`, at
the same bulk modulus): with the elastic mu a yielding element's hourglass modes held
a Taylor bar's foot from spreading (14.9 mm against the experiment's 16.2). The Q
already stored are not returned to a yield surface. On a distorted element the frame and half-lengths are those of the centre Jacobian: the
stiffness is then that of the rectangular element of the same centre Jacobian.

Each helper is inlined into its caller (``inline="always"``) and fills arrays it is
given, so the element loop allocates nothing; divisions by a variable go through
``fdiv`` (the same IEEE quotient), as in the material kernels: a ``/`` with Numba's
zero-divisor raise path keeps array reference counting live in the element loop.
"""
import numpy as np
from numba import njit

from ..materials.tensors import fdiv

#: the natural coordinates (xi, eta, zeta) of the VTK-ordered nodes
NATURAL = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], np.float64)


@njit(cache=True, inline="always")
def element_frame(xe, frame, half):
    """Fill ``frame`` (3, 3) with the corotational axes as columns (e_0 along the centre
    Jacobian's xi column, e_1 its eta column made orthogonal to e_0, e_2 = e_0 x e_1) and
    ``half`` (3,) with the half-lengths |g_k| of the element along xi, eta, zeta."""
    for k in range(3):
        for i in range(3):
            s = 0.0
            for node in range(8):
                s += NATURAL[node, k] * xe[node, i]
            frame[i, k] = 0.125 * s
        half[k] = np.sqrt(frame[0, k] ** 2 + frame[1, k] ** 2 + frame[2, k] ** 2)
    inv0 = fdiv(1.0, half[0])
    for i in range(3):
        frame[i, 0] *= inv0
    dot = frame[0, 0] * frame[0, 1] + frame[1, 0] * frame[1, 1] + frame[2, 0] * frame[2, 1]
    for i in range(3):
        frame[i, 1] -= dot * frame[i, 0]
    inv1 = fdiv(1.0, np.sqrt(frame[0, 1] ** 2 + frame[1, 1] ** 2 + frame[2, 1] ** 2))
    for i in range(3):
        frame[i, 1] *= inv1
    frame[0, 2] = frame[1, 0] * frame[2, 1] - frame[2, 0] * frame[1, 1]
    frame[1, 2] = frame[2, 0] * frame[0, 1] - frame[0, 0] * frame[2, 1]
    frame[2, 2] = frame[0, 0] * frame[1, 1] - frame[1, 0] * frame[0, 1]


@njit(cache=True, inline="always")
def plate_moduli(rho, c, shear, ratio):
    """(lam + 2 mu, mu, D1, D2) from the step's rho c^2 = lam + 2 mu and the shear
    modulus: D1 = E / (1 - nu^2) the plate modulus, D2 = nu D1 (lam taken as 0 where
    rho c^2 < 2 mu, as in pmpm.fem.stability). ``ratio`` < 1 (a yielding step,
    :func:`elastic_fraction`) scales mu down at the same bulk modulus."""
    mu = shear
    lam = max(rho * c * c - 2.0 * mu, 0.0)
    if ratio < 1.0:
        bulk = lam + 2.0 * mu / 3.0
        mu *= ratio
        lam = bulk - 2.0 * mu / 3.0
    inv = fdiv(1.0, lam + 2.0 * mu)
    return lam + 2.0 * mu, mu, 4.0 * mu * (lam + mu) * inv, 2.0 * mu * lam * inv


@njit(cache=True, inline="always")
def elastic_fraction(Lg, dt, deps_p):
    """The share of the step's deviatoric strain increment that the material took
    elastically, 1 - sqrt(3/2) d eps_p / |dev(D) dt| (at least 0): 1 in an elastic step,
    near 0 in a plastic one, so that the hourglass modes of a yielding element are not
    held by the elastic moduli (they would keep a Taylor bar's foot from spreading)."""
    if not deps_p > 0.0:
        return 1.0
    tr = (Lg[0, 0] + Lg[1, 1] + Lg[2, 2]) / 3.0
    sq = 0.0
    for i in range(3):
        for j in range(3):
            d = 0.5 * (Lg[i, j] + Lg[j, i]) - (tr if i == j else 0.0)
            sq += d * d
    return max(1.0 - np.sqrt(1.5) * deps_p * fdiv(1.0, np.sqrt(sq) * dt), 0.0)


@njit(cache=True, inline="always")
def stiffness_times(qd, half, volume, moduli, dq):
    """dq (4, 3) = K qd: the assumed-strain hourglass stiffness (see the module's
    docstring) times the local generalized coordinates (or rates) qd (4, 3), row a the
    mode, column i the local component."""
    p, mu, d1, d2 = moduli
    w = volume / 3.0
    l0, l1, l2 = half[0], half[1], half[2]
    s01 = fdiv(qd[0, 0], l1) + fdiv(qd[1, 1], l0)    # twist: the three shear strains
    s02 = fdiv(qd[0, 0], l2) + fdiv(qd[2, 2], l0)
    s12 = fdiv(qd[1, 1], l2) + fdiv(qd[2, 2], l1)
    dq[0, 0] = mu * w * (fdiv(s01, l1) + fdiv(s02, l2))
    dq[1, 1] = mu * w * (fdiv(s01, l0) + fdiv(s12, l2))
    dq[2, 2] = mu * w * (fdiv(s02, l0) + fdiv(s12, l1))
    for k in range(3):                               # bending across the thickness k
        i, j = (k + 1) % 3, (k + 2) % 3
        qi, qj = qd[j, i], qd[i, j]                  # u_i = xi_i xi_k, u_j = xi_j xi_k
        li, lj = half[i], half[j]
        dq[j, i] = w * (fdiv(d1 * qi, li * li) + fdiv(d2 * qj, li * lj))
        dq[i, j] = w * (fdiv(d2 * qi, li * lj) + fdiv(d1 * qj, lj * lj))
    for i in range(3):                               # xi eta zeta
        j, k = (i + 1) % 3, (i + 2) % 3
        dq[3, i] = w / 3.0 * (fdiv(p, half[i] ** 2) + fdiv(mu, half[j] ** 2)
                              + fdiv(mu, half[k] ** 2)) * qd[3, i]


@njit(cache=True, inline="always")
def largest_stiffness(half, volume, moduli):
    """An upper bound of the largest eigenvalue of K: the largest over its blocks (the
    2 x 2 bending blocks exactly, the twist block by its largest absolute row sum)."""
    p, mu, d1, d2 = moduli
    w = volume / 3.0
    l0, l1, l2 = half[0], half[1], half[2]
    # mu W B^T B, B's rows (1/l1, 1/l0, 0), (1/l2, 0, 1/l0), (0, 1/l2, 1/l1)
    a00 = fdiv(1.0, l1 * l1) + fdiv(1.0, l2 * l2)
    a11 = fdiv(1.0, l0 * l0) + fdiv(1.0, l2 * l2)
    a22 = fdiv(1.0, l0 * l0) + fdiv(1.0, l1 * l1)
    a01, a02, a12 = fdiv(1.0, l0 * l1), fdiv(1.0, l0 * l2), fdiv(1.0, l1 * l2)
    largest = mu * w * max(a00 + a01 + a02, max(a11 + a01 + a12, a22 + a02 + a12))
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        li, lj = half[i], half[j]
        kii, kjj, kij = fdiv(d1, li * li), fdiv(d1, lj * lj), fdiv(abs(d2), li * lj)
        mean, diff = 0.5 * (kii + kjj), 0.5 * (kii - kjj)
        largest = max(largest, w * (mean + np.sqrt(diff * diff + kij * kij)))
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        largest = max(largest, w / 3.0 * (fdiv(p, half[i] ** 2) + fdiv(mu, half[j] ** 2)
                                          + fdiv(mu, half[k] ** 2)))
    return largest


@njit(cache=True, inline="always")
def assumed_strain_forces(e, ve, gamma, volume, moduli, frame, half, dt, resist, qd, dq,
                          fe):
    """Subtract the assumed-strain hourglass forces of element ``e`` from ``fe``:
    the local rates qd = R^T gamma . v / 8, Q += dt K qd (``resist[e]`` holds Q, local,
    row-major by mode), f_I -= sum_a gamma_aI R Q_a / 8. Returns the work of the step
    (trapezoid: the change of the stored energy Q.q / 2)."""
    for a in range(4):
        g0 = g1 = g2 = 0.0
        for k in range(8):
            g0 += gamma[a, k] * ve[k, 0]
            g1 += gamma[a, k] * ve[k, 1]
            g2 += gamma[a, k] * ve[k, 2]
        for i in range(3):
            qd[a, i] = 0.125 * (frame[0, i] * g0 + frame[1, i] * g1 + frame[2, i] * g2)
    stiffness_times(qd, half, volume, moduli, dq)
    work = 0.0
    for a in range(4):
        for i in range(3):
            old = resist[e, 3 * a + i]
            new = old + dt * dq[a, i]
            resist[e, 3 * a + i] = new
            work += 0.5 * (old + new) * qd[a, i]
        q0, q1, q2 = resist[e, 3 * a], resist[e, 3 * a + 1], resist[e, 3 * a + 2]
        f0 = 0.125 * (frame[0, 0] * q0 + frame[0, 1] * q1 + frame[0, 2] * q2)
        f1 = 0.125 * (frame[1, 0] * q0 + frame[1, 1] * q1 + frame[1, 2] * q2)
        f2 = 0.125 * (frame[2, 0] * q0 + frame[2, 1] * q1 + frame[2, 2] * q2)
        for k in range(8):
            fe[k, 0] -= gamma[a, k] * f0
            fe[k, 1] -= gamma[a, k] * f1
            fe[k, 2] -= gamma[a, k] * f2
    return dt * work


@njit(cache=True, inline="always")
def assumed_strain_omega2(half, volume, rho, moduli, gram):
    """The hourglass stiffness's share of the element's largest omega^2: with lumped
    masses rho V / 8 and |q|^2 <= gram |u|^2 / 64 (``gram`` the Gram bound of the
    hourglass shapes), kappa gram / (8 rho V), kappa the bound of largest_stiffness."""
    return largest_stiffness(half, volume, moduli) * gram * fdiv(1.0, 8.0 * rho * volume)
