"""Per-particle constitutive update of every material model (Numba).

The fused stress kernel calls :func:`update_stress` once per particle with the particle's
velocity gradient; everything here is scalar code on register tuples (see
:mod:`pmpm.materials.tensors`), so the per-particle path allocates nothing.

One step of a particle, in order:

1. density ``rho <- rho / (1 + tr(D) dt)`` (seed 001 Eq. 30) and ``F <- (I + Lg dt) F``;
2. deviatoric stress of the model: hypoelastic Jaumann update (elastic, J2, Johnson-Cook,
   with a radial return for the plastic ones), Neo-Hookean from F, or fluid viscosity;
3. artificial bulk viscosity ``q`` from the volumetric rate;
4. pressure and specific internal energy together: hypoelastic ``p - K tr(de)`` (or the
   Neo-Hookean pressure) with an explicit energy update, or an EOS, for which the energy
   equation is solved in closed form;
5. the wave speed for the CFL condition, or -1.0 if anything is not finite.

Units are those of the case (CONTRACTS.md); stress is Voigt (xx, yy, zz, xy, yz, zx),
tension positive, pressure positive in compression.
"""
import math

from numba import njit

from .eos import bulk_viscosity, eos_pressure_coefficients, eos_tangent, mie_gruneisen_pressure
from .layout import (CHI, CP, EOS_C0, EOS_NONE, EOS_TYPE, EPS_FAIL, FLUID, G, J2_PLASTIC,
                     JOHNSON_COOK, K, NEO_HOOKEAN, Q_LINEAR, Q_QUADRATIC, RIGID,
                     TENSION_CUTOFF, VISCOSITY)
from .plasticity import return_map
from .tensors import (add, all_finite, deviator, double_dot, jaumann_rotate, load_row6, scale,
                      spin, store_stress, strain_rate, trace)

__all__ = ["update_stress", "wave_speed", "bulk_viscosity", "mie_gruneisen_pressure",
           "jaumann_rotate", "deviator", "neo_hookean_stress"]

ZERO6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@njit(cache=True)
def advance_deformation_gradient(F, p, Lg, dt):
    """``(I + Lg dt) F[p]`` as a row-major 9-tuple (F is not written)."""
    f0, f1, f2, f3, f4, f5, f6, f7, f8 = (F[p, 0], F[p, 1], F[p, 2], F[p, 3], F[p, 4],
                                          F[p, 5], F[p, 6], F[p, 7], F[p, 8])
    a00, a01, a02 = 1.0 + Lg[0, 0] * dt, Lg[0, 1] * dt, Lg[0, 2] * dt
    a10, a11, a12 = Lg[1, 0] * dt, 1.0 + Lg[1, 1] * dt, Lg[1, 2] * dt
    a20, a21, a22 = Lg[2, 0] * dt, Lg[2, 1] * dt, 1.0 + Lg[2, 2] * dt
    return (a00 * f0 + a01 * f3 + a02 * f6, a00 * f1 + a01 * f4 + a02 * f7,
            a00 * f2 + a01 * f5 + a02 * f8,
            a10 * f0 + a11 * f3 + a12 * f6, a10 * f1 + a11 * f4 + a12 * f7,
            a10 * f2 + a11 * f5 + a12 * f8,
            a20 * f0 + a21 * f3 + a22 * f6, a20 * f1 + a21 * f4 + a22 * f7,
            a20 * f2 + a21 * f5 + a22 * f8)


@njit(cache=True)
def store_row9(F, p, f):
    """Write a 9-tuple to row ``p`` of an (n, 9) array."""
    for i in range(9):
        F[p, i] = f[i]


@njit(cache=True)
def neo_hookean_stress(f, g, k):
    """Compressible Neo-Hookean Cauchy stress from a deformation gradient.

    Parameters
    ----------
    f : tuple of 9 float
        Deformation gradient, row-major.
    g, k : float
        Shear and bulk modulus.

    Returns
    -------
    s : tuple of 6 float
        Deviatoric stress ``(g/J) dev(B)``.
    pressure : float
        ``-[(g/J)(tr B - 3)/3 + lambda ln(J)/J]``; NaN when ``J <= 0``.

    Notes
    -----
    ``sigma = (g/J)(B - I) + (lambda ln J / J) I`` with ``B = F F^T``, ``J = det F`` and
    ``lambda = k - 2g/3``.
    """
    jac = (f[0] * (f[4] * f[8] - f[5] * f[7]) - f[1] * (f[3] * f[8] - f[5] * f[6])
           + f[2] * (f[3] * f[7] - f[4] * f[6]))
    if not jac > 0.0:
        return ZERO6, math.nan
    bxx = f[0] * f[0] + f[1] * f[1] + f[2] * f[2]
    byy = f[3] * f[3] + f[4] * f[4] + f[5] * f[5]
    bzz = f[6] * f[6] + f[7] * f[7] + f[8] * f[8]
    bxy = f[0] * f[3] + f[1] * f[4] + f[2] * f[5]
    byz = f[3] * f[6] + f[4] * f[7] + f[5] * f[8]
    bzx = f[6] * f[0] + f[7] * f[1] + f[8] * f[2]
    s = scale(deviator((bxx, byy, bzz, bxy, byz, bzx)), g / jac)
    lam = k - 2.0 * g / 3.0
    pressure = -(g / jac * (bxx + byy + bzz - 3.0) / 3.0 + lam * math.log(jac) / jac)
    return s, pressure


@njit(cache=True)
def hypoelastic_trial(sig_old, w, de, g, dt):
    """Rotated old deviator and elastic trial deviator of a hypoelastic step.

    Returns ``(s_rot, s_rot + 2 g dev(de))`` where ``s_rot`` is the deviator of the
    Jaumann-rotated old stress (rotation leaves the pressure unchanged).
    """
    s_rot = deviator(jaumann_rotate(sig_old, w, dt))
    return s_rot, add(s_rot, scale(deviator(de), 2.0 * g))


@njit(cache=True)
def has_failed(eps_p, eps_fail):
    """Particle failure of seed 001 Sec. 5.3: ``eps_fail > 0`` and ``eps_p >= eps_fail``."""
    return eps_fail > 0.0 and eps_p >= eps_fail


@njit(cache=True)
def plastic_step(p, prm, g, s_trial, eps_p, temp, dt, rho_mid):
    """Return map, plastic strain, adiabatic heating and failure of particle ``p``.

    Updates ``eps_p[p]`` and ``temp[p]``; returns ``(s, converged)``.

    Notes
    -----
    A failed particle (seed 001 Sec. 5.3) carries no deviatoric stress and its plastic
    strain no longer grows; a particle that reaches ``eps_fail`` during the step loses its
    deviator at the end of the step. Heating ``dT = chi sigma_y dlam / (rho cp)`` is applied
    when ``cp > 0`` (seed 001 Eq. 39 with the Taylor-Quinney factor chi).
    """
    eps_fail = prm[EPS_FAIL]
    if has_failed(eps_p[p], eps_fail):
        return ZERO6, True
    s, dlam, sigma_y, ok = return_map(prm, g, s_trial, eps_p[p], temp[p], dt)
    eps_p[p] += dlam
    if prm[CP] > 0.0:
        temp[p] += prm[CHI] * sigma_y * dlam / (rho_mid * prm[CP])
    if has_failed(eps_p[p], eps_fail):
        return ZERO6, ok
    return s, ok


@njit(cache=True)
def deviatoric_update(p, code, prm, dt, Lg, f_new, sig_old, p_old, dv, rho_mid, eps_p, temp):
    """Model-specific part of a step: new deviator, work deviator and strength pressure.

    Returns
    -------
    s_new : tuple of 6 float
        Deviatoric stress at the end of the step.
    s_work : tuple of 6 float
        Deviator whose contraction with ``de`` is the deviatoric work of the step.
    p_new : float
        End-of-step pressure without an EOS: ``p_old - K dv`` (hypoelastic, fluid) or the
        Neo-Hookean pressure; replaced by the EOS pressure when the row has one.
    converged : bool
        False when the return map failed.

    Notes
    -----
    Updates ``eps_p[p]`` and ``temp[p]`` of the plastic models.
    """
    d = strain_rate(Lg)
    g = prm[G]
    if code == NEO_HOOKEAN:
        s_new, p_new = neo_hookean_stress(f_new, g, prm[K])
        return s_new, scale(add(deviator(sig_old), s_new), 0.5), p_new, True
    if code == FLUID:
        s_new = scale(deviator(d), 2.0 * prm[VISCOSITY])
        return s_new, s_new, p_old - prm[K] * dv, True
    s_rot, s_new = hypoelastic_trial(sig_old, spin(Lg), scale(d, dt), g, dt)
    converged = True
    if code == J2_PLASTIC or code == JOHNSON_COOK:
        s_new, converged = plastic_step(p, prm, g, s_new, eps_p, temp, dt, rho_mid)
    return s_new, scale(add(s_rot, s_new), 0.5), p_old - prm[K] * dv, converged


@njit(cache=True)
def energy_known_pressure(e_old, work_dev, p_old, p_new, q, dv, rho_mid):
    """Specific internal energy after a step whose end pressure is known.

    ``e + [s_avg : de - ((p_old + p_new)/2 + q) tr(de)] / rho_mid`` (trapezoidal stress
    work; the bulk viscosity ``q`` acts over the whole step).
    """
    return e_old + (work_dev - (0.5 * (p_old + p_new) + q) * dv) / rho_mid


@njit(cache=True)
def pressure_and_energy(a, b, e_old, work_dev, p_old, q, dv, rho_mid):
    """End-of-step pressure and specific energy for an EOS ``p = a + b e``.

    Notes
    -----
    The energy equation ``e_new = e_old + [w_dev - ((p_old + p_new)/2 + q) dv]/rho_mid``
    with ``p_new = a + b e_new`` is linear in ``e_new``; its solution is
    ``e_new = (e_old + [w_dev - ((p_old + a)/2 + q) dv]/rho_mid) / (1 + b dv/(2 rho_mid))``
    (as LS-DYNA does for EOSs linear in energy), so no lag between p and e remains.
    """
    den = 1.0 + 0.5 * b * dv / rho_mid
    if not den > 0.0:
        return math.nan, math.nan
    e_new = (e_old + (work_dev - (0.5 * (p_old + a) + q) * dv) / rho_mid) / den
    return a + b * e_new, e_new


@njit(cache=True)
def wave_speed(code, prm, rho, pressure):
    """Wave speed of a particle for the CFL condition.

    Parameters
    ----------
    code : int
        Model code.
    prm : float64[N_SLOTS]
        Packed material row.
    rho : float
        Current density.
    pressure : float
        Current pressure (enters the Mie-Grueneisen isentropic slope).

    Returns
    -------
    float
        Solids: ``sqrt((K_t + 4G/3)/rho)`` with ``K_t = K``, or with an EOS
        ``K_t = max(K, rho dp/drho)``, so a compressed Mie-Grueneisen solid stiffens.
        Fluids: ``sqrt(max(dp/drho, c0^2))``: the EOS sound speed, never below c0.
        Rigid: 0.
    """
    if code == RIGID:
        return 0.0
    k_t = prm[K]
    if prm[EOS_TYPE] != EOS_NONE:
        k_t = max(k_t, rho * eos_tangent(prm, rho, pressure))
    if code == FLUID:
        k_t = max(k_t, rho * prm[EOS_C0] * prm[EOS_C0])
    return math.sqrt(max(k_t + 4.0 / 3.0 * prm[G], 0.0) / rho)


@njit(cache=True)
def update_stress(p, code, prm, dt, h, Lg, stress, F, rho, eps_p, e_int, temp, q):
    """Advance the stress and state of particle ``p`` over one step.

    Parameters
    ----------
    p : int
        Particle index into the column arrays.
    code : int
        Model code (``pmpm.materials.layout``).
    prm : float64[N_SLOTS]
        Packed material row (``pmpm.materials.catalog.pack``).
    dt : float
        Time step.
    h : float
        Characteristic length of the bulk viscosity (cell size).
    Lg : float64[3, 3]
        Velocity gradient at the particle, ``Lg[i, j] = dv_i/dx_j``.
    stress, F, rho, eps_p, e_int, temp, q : arrays
        Particle columns (CONTRACTS.md), updated in place at row ``p``.

    Returns
    -------
    float
        The particle's wave speed (:func:`wave_speed`); -1.0 when the update failed
        (non-finite stress, energy or wave speed, non-positive density or Jacobian, or a
        return map that did not converge); 0.0 for a rigid particle, which is not touched.

    Notes
    -----
    ``D = sym(Lg)``, ``W = skew(Lg)``, ``de = D dt``, ``dv = tr(de)``.

    * elastic: ``sigma <- sigma + (W sigma - sigma W) dt + lambda dv I + 2 G de``, written
      as a deviator ``s_rot + 2G dev(de)`` plus a pressure ``p - K dv``.
    * j2 / johnson_cook: the same trial deviator, then a radial return
      (:func:`pmpm.materials.plasticity.return_map`), heating, failure.
    * neo_hookean: stress from ``F`` after ``F <- (I + Lg dt) F``.
    * fluid: deviator ``2 eta dev(D)``; pressure from the EOS, limited to
      ``p >= -tension_cutoff``.

    With an EOS the pressure of any model comes from it instead. The specific energy
    takes the trapezoidal stress work ``[s_avg : de - (p_avg + q) dv] / rho_mid``, with
    ``s_avg`` the mean of the rotated old and the new deviator (the fluid's viscous
    deviator is a rate, so it uses the new one: dissipation is ``2 eta dev(D):dev(D) dt``),
    and ``rho_mid`` the mean of the old and new density. ``q`` (stored, not added to the
    stress) uses the sound speed at the new density and old pressure.
    """
    if code == RIGID:
        return 0.0
    d = strain_rate(Lg)
    dv = trace(d) * dt
    if not 1.0 + dv > 0.0:
        return -1.0
    rho_old = rho[p]
    rho_new = rho_old / (1.0 + dv)
    if not (rho_new > 0.0 and math.isfinite(rho_new)):
        return -1.0
    rho_mid = 0.5 * (rho_old + rho_new)
    f_new = advance_deformation_gradient(F, p, Lg, dt)
    sig_old = load_row6(stress, p)
    p_old = -trace(sig_old) / 3.0
    s_new, s_work, p_new, converged = deviatoric_update(p, code, prm, dt, Lg, f_new, sig_old,
                                                        p_old, dv, rho_mid, eps_p, temp)
    q_new = bulk_viscosity(rho_new, h, wave_speed(code, prm, rho_new, p_old), trace(d),
                           prm[Q_LINEAR], prm[Q_QUADRATIC])
    work_dev = double_dot(s_work, scale(d, dt))
    if prm[EOS_TYPE] != EOS_NONE:
        a, b = eos_pressure_coefficients(prm, rho_new)
        p_new, e_new = pressure_and_energy(a, b, e_int[p], work_dev, p_old, q_new, dv, rho_mid)
    else:
        e_new = energy_known_pressure(e_int[p], work_dev, p_old, p_new, q_new, dv, rho_mid)
    if code == FLUID and p_new < -prm[TENSION_CUTOFF]:
        p_new = -prm[TENSION_CUTOFF]
        e_new = energy_known_pressure(e_int[p], work_dev, p_old, p_new, q_new, dv, rho_mid)
    c = wave_speed(code, prm, rho_new, p_new)
    if not (converged and all_finite(s_new) and math.isfinite(p_new)
            and math.isfinite(e_new) and math.isfinite(c)):
        return -1.0
    store_stress(stress, p, s_new, p_new)
    store_row9(F, p, f_new)
    rho[p] = rho_new
    e_int[p] = e_new
    q[p] = q_new
    return c
