"""Per-particle constitutive update of every material model (Numba).

The fused stress kernel calls :func:`update_stress` once per particle with the particle's
velocity gradient; everything here is scalar code on register tuples (see
:mod:`pmpm.materials.tensors`), so the per-particle path allocates nothing.

One step of a particle, in order:

1. density ``rho <- rho / (1 + tr(D) dt)`` (seed 001 Eq. 30) and ``F <- (I + Lg dt) F``;
2. deviatoric stress of the model: hypoelastic Jaumann update (elastic, J2, Johnson-Cook,
   with a radial return for the plastic ones, which also sum the plastic work and the
   damage), Neo-Hookean from F, or fluid viscosity;
3. artificial bulk viscosity ``q`` from the volumetric rate;
4. pressure and specific internal energy together: hypoelastic ``p - K tr(de)`` (or the
   Neo-Hookean pressure) with an explicit energy update, or an EOS, for which the energy
   equation is solved in closed form; the work is the trapezoid over the step's exact
   change of specific volume;
   with a damage model, a failed point (damage 1, or a pressure below the spall cut-off)
   then loses its deviator and its tension (:func:`damaged_failure`);
5. the wave speed for the CFL condition, or -1.0 if anything is not finite (Neo-Hookean:
   the stiffer of the small-strain speed and :func:`neo_hookean_wave_speed` at the new F).

Units are those of the case (CONTRACTS.md); stress is Voigt (xx, yy, zz, xy, yz, zx),
tension positive, pressure positive in compression.

Speed
-----
:func:`update_stress` and every helper it calls are compiled once each and marked for
LLVM to inline (``forceinline=True``, LLVM's ``alwaysinline``): the linked kernel holds
the whole update in the caller's particle loop, so no tuple goes through memory, no call
passes the particle columns, and LLVM schedules the whole update at once. Numba's
IR-level inlining (``inline="always"``), used before, gave the same machine code but typed
the whole update afresh in every kernel specialisation (each shape, with and without
contact): two thirds of the cold compile of :func:`pmpm.kernels.mpm.stress_and_forces`
(docs/performance-notes.md, "Cold compile"). Inside, the arrays are read first and
written last, outside any branch, and every division goes through
:func:`pmpm.materials.tensors.fdiv`: an array touched in a branch, or a ZeroDivisionError
path, keeps Numba's reference counting of the arrays alive in the compiled loop (atomic
operations on every particle). The update itself (:func:`material_step`) works on values
only; it is bound by its chain of dependent divisions and square roots more than by its
arithmetic, so:

* with an EOS, the Hugoniot at the new density is evaluated once and serves the pressure
  and both wave speeds, the stiffness ``rho dp/drho`` is written ``kt0 + kt1 P`` and the
  energy solve and wave speed multiply by ``1/den`` and ``1/rho`` taken off the chain;
* linear hardening without rate term (the Taylor bar's copper) is a closed form, one
  square root, and the return factor ``sigma_y/q_trial`` takes one division after it;
  the deviatoric work of a plastic model is ``(s_rot:de + factor s_trial:de)/2``.

* the plastic models (j2 and Johnson-Cook, the same arithmetic) take their own inlined
  copy of :func:`material_step`, with the model code a constant, so the other models'
  branches are compiled out of it: LLVM then keeps the plastic path's values in
  registers rather than spilling them to the stack around the other models' code
  (the bar's update 37 -> 34 ns a particle, bit for bit);
* a trial stress surely inside the yield surface (``q^2 < (1 - 1e-9) sy0^2``) skips the
  square root of the von Mises stress, and a model without bulk viscosity coefficients
  skips the viscosity (and without an EOS the wave speed is taken once): the same bits.

These regroupings change results by round-off only (relative 1e-16 per step; models
without an EOS that are not plastic are bit-for-bit the straightforward formulas).
"""
import math

from numba import njit

from .eos import bulk_viscosity, eos_at_density, mie_gruneisen_pressure
from .layout import (A, B, C, CHI, CP, D1, D2, D3, D4, D5, DAMAGE, DAMAGE_NONE, EOS_C0,
                     EOS_GAMMA0, EOS_NONE, EOS_S, EOS_TYPE, EPS_DOT0, EPS_FAIL, FLUID, G,
                     J2_PLASTIC, JOHNSON_COOK, K, M, N, N_SLOTS, NEO_HOOKEAN, Q_LINEAR,
                     Q_QUADRATIC, RHO0, RIGID, SPALL, T_MELT, T_ROOM, TENSION_CUTOFF,
                     VISCOSITY)
from .plasticity import hardening, plastic_increment, thermal_factor
from .tensors import (add, all_finite, determinant9, deviator, double_dot, fdiv,
                      jaumann_rotate, left_cauchy_green, scale,
                      skew9, sym9, trace, von_mises)

__all__ = ["update_stress", "wave_speed", "bulk_viscosity", "mie_gruneisen_pressure",
           "jaumann_rotate", "deviator", "neo_hookean_stress", "neo_hookean_wave_speed"]

ZERO6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
# A trial stress with (q_trial / sy0)^2 below this (sy0 > 0) is elastic by
# plastic_increment's own test (q_trial - sy0 <= 1e-11 q_trial) whatever the round-off of
# the square root (a relative 1e-16): such a step skips the square root (plastic_step).
SURELY_ELASTIC = 1.0 - 1e-9
if N_SLOTS != 31:
    raise ImportError("update_stress reads a parameter row of 31 slots: update it with layout")


@njit(cache=True, forceinline=True)
def advance_deformation_gradient(f, l, dt):
    """``(I + Lg dt) F`` for ``F`` (``f``) and ``Lg`` (``l``) given as row-major 9-tuples."""
    f0, f1, f2, f3, f4, f5, f6, f7, f8 = f
    a00, a01, a02 = 1.0 + l[0] * dt, l[1] * dt, l[2] * dt
    a10, a11, a12 = l[3] * dt, 1.0 + l[4] * dt, l[5] * dt
    a20, a21, a22 = l[6] * dt, l[7] * dt, 1.0 + l[8] * dt
    return (a00 * f0 + a01 * f3 + a02 * f6, a00 * f1 + a01 * f4 + a02 * f7,
            a00 * f2 + a01 * f5 + a02 * f8,
            a10 * f0 + a11 * f3 + a12 * f6, a10 * f1 + a11 * f4 + a12 * f7,
            a10 * f2 + a11 * f5 + a12 * f8,
            a20 * f0 + a21 * f3 + a22 * f6, a20 * f1 + a21 * f4 + a22 * f7,
            a20 * f2 + a21 * f5 + a22 * f8)


@njit(cache=True, forceinline=True)
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
    jac = determinant9(f)
    if not jac > 0.0:
        return ZERO6, math.nan
    bxx, byy, bzz, bxy, byz, bzx = left_cauchy_green(f)
    g_j = fdiv(g, jac)
    s = scale(deviator((bxx, byy, bzz, bxy, byz, bzx)), g_j)
    lam = k - 2.0 * g / 3.0
    pressure = -(g_j * (bxx + byy + bzz - 3.0) / 3.0 + fdiv(lam * math.log(jac), jac))
    return s, pressure


@njit(cache=True, forceinline=True)
def neo_hookean_wave_speed(f, g, k, rho):
    """Largest longitudinal wave speed of the compressible Neo-Hookean solid at ``F``
    (``f``, ``g``, ``k`` as in :func:`neo_hookean_stress`) and current density ``rho``.

    Returns
    -------
    float
        ``sqrt(max_n A_nn / rho)`` with the acoustic tensor of the strain energy
        ``W = (g/2)(tr C - 3) - g ln J + (lambda/2) ln^2 J`` (the stress of
        :func:`neo_hookean_stress`): ``J A = g (n.B.n) I + (lambda + g - lambda ln J) n n``,
        whose largest eigenvalue over directions n is ``(g b_max + g + lambda (1 - ln J))/J``.
        ``b_max`` is bounded above by ``tr B/3 + 2 sqrt(|dev B|^2/6)`` (exact when the two
        smaller principal stretches are equal, e.g. at ``F = I``, where the speed is
        ``sqrt((k + 4g/3)/rho)``). In compression (``J < 1``) the solid stiffens: at
        ``J = 0.65`` the speed is 1.4 times the small-strain one at the same density.
        NaN when ``J <= 0``.
    """
    jac = determinant9(f)
    if not jac > 0.0:
        return math.nan
    bxx, byy, bzz, bxy, byz, bzx = left_cauchy_green(f)
    mean = (bxx + byy + bzz) / 3.0
    dev2 = ((bxx - mean) ** 2 + (byy - mean) ** 2 + (bzz - mean) ** 2
            + 2.0 * (bxy * bxy + byz * byz + bzx * bzx))
    b_max = mean + 2.0 * math.sqrt(dev2 / 6.0)
    lam = k - 2.0 * g / 3.0
    stiffness = g * b_max + g + lam * (1.0 - math.log(jac))
    return math.sqrt(fdiv(max(stiffness, 0.0), jac * rho))


@njit(cache=True, forceinline=True)
def has_failed(eps_p, eps_fail):
    """Particle failure of seed 001 Sec. 5.3: ``eps_fail > 0`` and ``eps_p >= eps_fail``."""
    return eps_fail > 0.0 and eps_p >= eps_fail


@njit(cache=True, forceinline=True)
def fracture_strain(triax, rate_ratio, t_star, d1, d2, d3, d4, d5):
    """Johnson-Cook (1985) equivalent plastic strain at fracture.

    ``eps_f = [d1 + d2 exp(d3 triax)] [1 + d4 ln max(rate_ratio, 1)] [1 + d5 t_star]``
    with ``triax`` the stress triaxiality (mean stress over von Mises stress, tension
    positive), ``rate_ratio`` the plastic strain rate over the reference rate and
    ``t_star`` the homologous temperature. The exponent is capped at 700 (exp stays
    finite); a factor whose constant is 0 is not evaluated.
    """
    eps_f = d1 + d2 * math.exp(min(d3 * triax, 700.0))
    if d4 != 0.0 and rate_ratio > 1.0:
        eps_f *= 1.0 + d4 * math.log(rate_ratio)
    if d5 != 0.0:
        eps_f *= 1.0 + d5 * t_star
    return eps_f


@njit(cache=True, forceinline=True)
def homologous_temperature(temp, t_room, t_melt):
    """``T* = (T - T_room)/(T_melt - T_room)`` clipped to [0, 1], as the Johnson-Cook
    strength's (:func:`pmpm.materials.plasticity.thermal_factor`); 0 when
    ``T_melt <= T_room`` (a row without temperatures)."""
    if t_melt <= t_room:
        return 0.0
    return min(max(fdiv(temp - t_room, t_melt - t_room), 0.0), 1.0)


@njit(cache=True, forceinline=True)
def damage_after(dam0, eps1, dlam, dt, p_old, sigma_y, temp0, prm):
    """The damage at the end of a step with plastic increment ``dlam``, at most 1.

    With a Johnson-Cook damage model (slot ``DAMAGE``): ``D = D0 + dlam / eps_f``
    (:func:`fracture_strain`) at the triaxiality ``-p_old / sigma_y`` (the start-of-step
    pressure over the step's flow stress, which is the von Mises stress of the returned
    deviator), the rate ``dlam / dt`` over the row's ``EPS_DOT0`` and ``T*`` of the
    start-of-step temperature; ``eps_f <= 0`` fails the point at once. Without one but with
    ``eps_fail``: ``eps_p / eps_fail`` (1 exactly when :func:`has_failed`). Else 0.
    """
    if prm[DAMAGE] != DAMAGE_NONE:
        if not dlam > 0.0:
            return dam0
        triax = fdiv(-p_old, sigma_y) if sigma_y > 0.0 else 0.0
        rate_ratio = fdiv(dlam, dt * prm[EPS_DOT0]) if prm[EPS_DOT0] > 0.0 else 0.0
        t_star = homologous_temperature(temp0, prm[T_ROOM], prm[T_MELT])
        eps_f = fracture_strain(triax, rate_ratio, t_star, prm[D1], prm[D2], prm[D3],
                                prm[D4], prm[D5])
        if not eps_f > 0.0:
            return 1.0
        return min(dam0 + fdiv(dlam, eps_f), 1.0)
    if prm[EPS_FAIL] > 0.0:
        return min(fdiv(eps1, prm[EPS_FAIL]), 1.0)
    return dam0


@njit(cache=True, forceinline=True)
def plastic_step(s_trial, g, eps0, temp0, dam0, wp0, dt, rho_mid, p_old, prm):
    """Return map, plastic strain, adiabatic heating, plastic work, damage and failure of
    one particle.

    Parameters
    ----------
    s_trial : tuple of 6 float
        Elastic trial deviator.
    g : float
        Shear modulus.
    eps0, temp0, dam0, wp0 : float
        Plastic strain, temperature, damage and specific plastic work at the start of
        the step.
    dt, rho_mid, p_old : float
        Time step, mid-step density, start-of-step pressure (the damage's triaxiality).
    prm : tuple of N_SLOTS float
        The packed row (its plastic, failure and damage slots).

    Returns
    -------
    s : tuple of 6 float
        Deviatoric stress at the end of the step, ``factor * s_trial``.
    factor : float
        1 for an elastic step, ``sigma_y / q_trial`` for a plastic one, 0 for a failed
        particle.
    eps1, temp1, dam1, wp1 : float
        Plastic strain, temperature, damage and specific plastic work at the end of the
        step.
    converged : bool
        False when the return map failed.

    Notes
    -----
    A failed particle (seed 001 Sec. 5.3: ``eps_p >= eps_fail``; or damage ``D >= 1``)
    carries no deviatoric stress and its plastic strain no longer grows; a particle that
    fails during the step loses its deviator at the end of the step (a damage model's
    failed point also loses its tension: :func:`material_step`). Heating
    ``dT = chi sigma_y dlam / (rho cp)`` is applied when ``cp > 0`` (seed 001 Eq. 39 with
    the Taylor-Quinney factor chi); the plastic work per mass ``sigma_y dlam / rho`` is
    summed in any case. The thermal factor uses the start-of-step temperature. Linear
    hardening without rate term takes the closed form of
    :func:`pmpm.materials.plasticity.plastic_increment`: one square root (the von Mises
    stress), no other transcendental call.
    """
    eps_fail = prm[EPS_FAIL]
    if has_failed(eps0, eps_fail) or dam0 >= 1.0:
        return ZERO6, 0.0, eps0, temp0, dam0, wp0, True
    theta = thermal_factor(prm[M], temp0, prm[T_ROOM], prm[T_MELT])
    q2 = 1.5 * double_dot(s_trial, s_trial)
    sy0 = theta * hardening(prm[A], prm[B], prm[N], eps0)
    elastic = sy0 > 0.0 and q2 < SURELY_ELASTIC * (sy0 * sy0)
    if elastic:         # plastic_increment's elastic answer, without the square root
        q_trial, dlam, sigma_y, ratio, ok = 0.0, 0.0, sy0, 1.0, True
    else:
        q_trial = math.sqrt(q2)
        dlam, sigma_y, ratio, ok = plastic_increment(q_trial, g, eps0, dt, prm[A], prm[B],
                                                     prm[N], prm[C], prm[EPS_DOT0], theta)
    eps1 = eps0 + dlam
    temp1 = temp0
    if prm[CP] > 0.0:       # (chi sigma_y) dlam: the order of the products of before
        temp1 = temp0 + fdiv(prm[CHI] * sigma_y * dlam, rho_mid * prm[CP])
    wp1 = wp0 + fdiv(sigma_y * dlam, rho_mid)
    dam1 = damage_after(dam0, eps1, dlam, dt, p_old, sigma_y, temp0, prm)
    if has_failed(eps1, eps_fail) or dam1 >= 1.0:
        return ZERO6, 0.0, eps1, temp1, dam1, wp1, ok
    if elastic or q_trial <= sigma_y:
        return s_trial, 1.0, eps1, temp1, dam1, wp1, ok
    return scale(s_trial, ratio), ratio, eps1, temp1, dam1, wp1, ok


@njit(cache=True, forceinline=True)
def energy_known_pressure(e_old, work_dev, p_old, p_new, q, dvs, v_mid):
    """Specific internal energy after a step whose end pressure is known.

    ``e + s_avg : de v_mid - ((p_old + p_new)/2 + q) dvs``: trapezoidal stress work per
    unit mass, with ``dvs`` the step's exact change of specific volume ``1/rho_new -
    1/rho_old`` and ``v_mid`` the mean specific volume (the deviatoric work ``s_avg : de``
    is per unit current volume); the bulk viscosity ``q`` acts over the whole step.
    """
    return e_old + (work_dev * v_mid - (0.5 * (p_old + p_new) + q) * dvs)


@njit(cache=True, forceinline=True)
def pressure_and_energy(a, b, e_old, work_dev, p_old, q, dvs, v_mid):
    """End-of-step pressure and specific energy for an EOS ``p = a + b e``.

    Notes
    -----
    The energy equation ``e_new = e_old + w_dev v_mid - ((p_old + p_new)/2 + q) dvs``
    (:func:`energy_known_pressure`) with ``p_new = a + b e_new`` is linear in ``e_new``;
    its solution is ``e_new = (e_old + w_dev v_mid - ((p_old + a)/2 + q) dvs) /
    (1 + b dvs/2)`` (as LS-DYNA does for EOSs linear in energy), so no lag between p and
    e remains. With ``dvs`` the exact change of specific volume, a step that jumps from
    the unshocked state to a density on the Hugoniot lands on the Hugoniot: the
    trapezoid ``(p_0 + p_1)(v_0 - v_1)/2`` is the Rankine-Hugoniot energy jump.
    """
    den = 1.0 + 0.5 * b * dvs
    if not den > 0.0:
        return math.nan, math.nan
    # 1/den does not wait for the deviatoric work: one multiply at the end of the chain
    e_new = (e_old + (work_dev * v_mid - (0.5 * (p_old + a) + q) * dvs)) * fdiv(1.0, den)
    return a + b * e_new, e_new


@njit(cache=True, forceinline=True)
def bulk_stiffness(code, k_bulk, has_eos, kt0, kt1, pressure, rho, c0):
    """``K_t`` of :func:`wave_speed` at ``pressure``; with an EOS ``rho dp/drho`` is
    ``kt0 + kt1 pressure`` (:func:`pmpm.materials.eos.eos_at_density`)."""
    k_t = k_bulk
    if has_eos:
        k_t = max(k_t, kt0 + kt1 * pressure)
    if code == FLUID:
        k_t = max(k_t, rho * c0 * c0)
    return k_t


@njit(cache=True, forceinline=True)
def speed_from_stiffness(k_t, g43, rho):
    """``sqrt((K_t + 4G/3)/rho)``, ``g43 = 4G/3``."""
    return math.sqrt(fdiv(max(k_t + g43, 0.0), rho))


@njit(cache=True, forceinline=True)
def speed_from_inverse(k_t, g43, inv_rho):
    """``sqrt((K_t + 4G/3) / rho)`` with ``inv_rho = 1/rho`` (a multiply, not a division,
    at the end of the chain of a step with an EOS)."""
    return math.sqrt(max(k_t + g43, 0.0) * inv_rho)


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
        Rigid: 0. The same arithmetic as the speed :func:`update_stress` returns for the
        end-of-step density and pressure, except for the Neo-Hookean solid, whose update
        returns the larger of this and :func:`neo_hookean_wave_speed` at its new F (a
        speed that needs F, which this function is not given).
    """
    if code == RIGID:
        return 0.0
    eos_type = prm[EOS_TYPE]
    g43 = 4.0 / 3.0 * prm[G]
    if eos_type == EOS_NONE:
        k_t = bulk_stiffness(code, prm[K], False, 0.0, 0.0, pressure, rho, prm[EOS_C0])
        return speed_from_stiffness(k_t, g43, rho)
    _, _, kt0, kt1 = eos_at_density(eos_type, rho, prm[RHO0], prm[EOS_C0], prm[EOS_S],
                                    prm[EOS_GAMMA0])
    k_t = bulk_stiffness(code, prm[K], True, kt0, kt1, pressure, rho, prm[EOS_C0])
    return speed_from_inverse(k_t, g43, fdiv(1.0, rho))


@njit(cache=True, forceinline=True)
def damaged_failure(s_new, p_new, e_new, dam1, factor, w_rot, spall, e_old, p_old, q, dvs,
                    v_mid):
    """Failure of a point of a material with a damage model, at the end of its step.

    A point fails when its damage reaches 1 or, with ``spall > 0``, when its pressure
    falls below ``-spall`` (the spall cut-off). A failed point keeps no deviatoric stress
    (one that fails by spall now loses the deviator of this step: the deviatoric work is
    then the trapezoid ``s_rot : de / 2``, ``w_rot`` = ``s_rot : de``) and no tension
    (pressure at least 0); the energy is then that of the clamped pressure
    (:func:`energy_known_pressure`), as for the fluid's tension cut-off.

    Returns
    -------
    s_new, p_new, e_new, dam1
        The end-of-step deviator, pressure, specific energy and damage (1 when failed).
    """
    spalled = spall > 0.0 and p_new < -spall
    if not (dam1 >= 1.0 or spalled):
        return s_new, p_new, e_new, dam1
    changed = False
    work_dev = 0.5 * w_rot
    if factor != 0.0:
        s_new = ZERO6
        changed = True
    if p_new < 0.0:
        p_new = 0.0
        changed = True
    if changed:
        e_new = energy_known_pressure(e_old, work_dev, p_old, p_new, q, dvs, v_mid)
    return s_new, p_new, e_new, 1.0


@njit(cache=True, forceinline=True)
def material_step(code, prm, dt, h, lg, sig_old, f_old, rho_old, eps_old, e_old, temp_old,
                  q_old, dam_old, wp_old):
    """One particle's constitutive step on values (the arithmetic of :func:`update_stress`).

    Parameters
    ----------
    code : int
        Model code.
    prm : tuple of N_SLOTS float
        The packed material row.
    dt, h : float
        Time step, bulk-viscosity length.
    lg : tuple of 9 float
        Velocity gradient, row-major.
    sig_old : tuple of 6 float
        Stress at the start of the step.
    f_old : tuple of 9 float
        Deformation gradient at the start of the step, row-major.
    rho_old, eps_old, e_old, temp_old, q_old, dam_old, wp_old : float
        Density, plastic strain, specific energy, temperature, bulk viscosity, damage and
        specific plastic work at the start of the step.

    Returns
    -------
    tuple
        ``(c, stress, F, rho, eps_p, e_int, temp, q, damage, w_p)``: the return value of
        :func:`update_stress` and the values to store. A failed or rigid update returns the
        old values, except that ``eps_p``, ``temp``, ``damage`` and ``w_p`` are those of
        the return map whenever it ran.
    """
    if code == RIGID:
        return 0.0, sig_old, f_old, rho_old, eps_old, e_old, temp_old, q_old, dam_old, wp_old
    d = sym9(lg)
    div = trace(d)
    dv = div * dt
    if not 1.0 + dv > 0.0:
        return -1.0, sig_old, f_old, rho_old, eps_old, e_old, temp_old, q_old, dam_old, wp_old
    rho_new = fdiv(rho_old, 1.0 + dv)
    if not (rho_new > 0.0 and math.isfinite(rho_new)):
        return -1.0, sig_old, f_old, rho_old, eps_old, e_old, temp_old, q_old, dam_old, wp_old
    rho_mid = 0.5 * (rho_old + rho_new)
    # specific volume: its exact change over the step (rho_new = rho_old / (1 + dv)) and
    # its mean, for the energy equation
    v_old = fdiv(1.0, rho_old)
    dvs = dv * v_old
    v_mid = v_old + 0.5 * dvs
    g = prm[G]
    k_bulk = prm[K]
    p_old = -trace(sig_old) / 3.0
    de = scale(d, dt)

    # deviatoric part, by model; work_dev = s_avg : de
    converged = True
    eps1 = eps_old
    temp1 = temp_old
    dam1 = dam_old
    wp1 = wp_old
    w_rot = 0.0
    factor = 1.0
    if code == NEO_HOOKEAN:
        s_new, p_new = neo_hookean_stress(advance_deformation_gradient(f_old, lg, dt), g,
                                          k_bulk)
        work_dev = double_dot(scale(add(deviator(sig_old), s_new), 0.5), de)
    elif code == FLUID:
        s_new = scale(deviator(d), 2.0 * prm[VISCOSITY])
        work_dev = double_dot(s_new, de)
        p_new = p_old - k_bulk * dv
    else:
        s_rot = deviator(jaumann_rotate(sig_old, skew9(lg), dt))
        s_new = add(s_rot, scale(deviator(de), 2.0 * g))
        if code == J2_PLASTIC or code == JOHNSON_COOK:
            # s_avg : de = (s_rot : de + factor s_trial : de)/2, both products ready
            # before the return map ends (equal to the elastic form up to round-off)
            w_rot = double_dot(s_rot, de)
            w_trial = double_dot(s_new, de)
            s_new, factor, eps1, temp1, dam1, wp1, converged = plastic_step(
                s_new, g, eps_old, temp_old, dam_old, wp_old, dt, rho_mid, p_old, prm)
            work_dev = 0.5 * (w_rot + factor * w_trial)
        else:
            work_dev = double_dot(scale(add(s_rot, s_new), 0.5), de)
        p_new = p_old - k_bulk * dv

    # volumetric part: the EOS at the new density once, for pressure and both wave speeds
    eos_type = prm[EOS_TYPE]
    has_eos = eos_type != EOS_NONE
    c0 = prm[EOS_C0]
    g43 = 4.0 / 3.0 * g
    a = b = kt0 = kt1 = inv_rho = 0.0
    if has_eos:
        a, b, kt0, kt1 = eos_at_density(eos_type, rho_new, prm[RHO0], c0, prm[EOS_S],
                                        prm[EOS_GAMMA0])
        inv_rho = fdiv(1.0, rho_new)
    k_old = bulk_stiffness(code, k_bulk, has_eos, kt0, kt1, p_old, rho_new, c0)
    c_old = 0.0
    if not has_eos:
        c_old = speed_from_stiffness(k_old, g43, rho_new)
    q_new = 0.0
    if not div >= 0.0 and (prm[Q_LINEAR] != 0.0 or prm[Q_QUADRATIC] != 0.0):
        if has_eos:
            c_old = speed_from_inverse(k_old, g43, inv_rho)
        q_new = bulk_viscosity(rho_new, h, c_old, div, prm[Q_LINEAR], prm[Q_QUADRATIC])
    if has_eos:
        p_new, e_new = pressure_and_energy(a, b, e_old, work_dev, p_old, q_new, dvs, v_mid)
    else:
        e_new = energy_known_pressure(e_old, work_dev, p_old, p_new, q_new, dvs, v_mid)
    if code == FLUID and p_new < -prm[TENSION_CUTOFF]:
        p_new = -prm[TENSION_CUTOFF]
        e_new = energy_known_pressure(e_old, work_dev, p_old, p_new, q_new, dvs, v_mid)
    if prm[DAMAGE] != DAMAGE_NONE:
        s_new, p_new, e_new, dam1 = damaged_failure(s_new, p_new, e_new, dam1, factor, w_rot,
                                                    prm[SPALL], e_old, p_old, q_new, dvs,
                                                    v_mid)
    if has_eos:
        c = speed_from_inverse(bulk_stiffness(code, k_bulk, True, kt0, kt1, p_new, rho_new, c0),
                               g43, inv_rho)
    else:
        c = c_old
    if code == NEO_HOOKEAN:
        # the stiffer of the small-strain speed and that of the current state (it grows in
        # compression), so that the CFL step (seed 001 Eq. 35) follows the stiffened solid
        c = max(c, neo_hookean_wave_speed(advance_deformation_gradient(f_old, lg, dt), g,
                                          k_bulk, rho_new))
    if not (converged and all_finite(s_new) and math.isfinite(p_new) and math.isfinite(e_new)
            and math.isfinite(c)):
        return -1.0, sig_old, f_old, rho_old, eps1, e_old, temp1, q_old, dam1, wp1
    sig_new = (s_new[0] - p_new, s_new[1] - p_new, s_new[2] - p_new, s_new[3], s_new[4],
               s_new[5])
    return (c, sig_new, advance_deformation_gradient(f_old, lg, dt), rho_new, eps1, e_new,
            temp1, q_new, dam1, wp1)


@njit(cache=True, forceinline=True)
def update_stress(p, code, prm, dt, h, Lg, mat):
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
    mat : MaterialState
        The material columns (``pmpm.materials.state``: stress, F, rho, eps_p, e_int,
        temp, q, damage, w_p), updated in place at row ``p``.

    Returns
    -------
    float
        The particle's wave speed (:func:`wave_speed`; Neo-Hookean: at least
        :func:`neo_hookean_wave_speed` at the new F); -1.0 when the update failed
        (non-finite stress, energy or wave speed, non-positive density or Jacobian, or a
        return map that did not converge); 0.0 for a rigid particle, which is not touched.
        A failed update leaves the particle's columns as they were, except the plastic
        strain and temperature of a return map that ran.

    Notes
    -----
    ``D = sym(Lg)``, ``W = skew(Lg)``, ``de = D dt``, ``dv = tr(de)``.

    * elastic: ``sigma <- sigma + (W sigma - sigma W) dt + lambda dv I + 2 G de``, written
      as a deviator ``s_rot + 2G dev(de)`` plus a pressure ``p - K dv``.
    * j2 / johnson_cook: the same trial deviator, then a radial return
      (:func:`pmpm.materials.plasticity.return_map`), heating, plastic work, damage and
      failure (:func:`plastic_step`; with a damage model also the spall cut-off and no
      tension once failed, :func:`damaged_failure`).
    * neo_hookean: stress from ``F`` after ``F <- (I + Lg dt) F``.
    * fluid: deviator ``2 eta dev(D)``; pressure from the EOS, limited to
      ``p >= -tension_cutoff``.

    With an EOS the pressure of any model comes from it instead. The specific energy
    takes the trapezoidal stress work ``s_avg : de v_mid - (p_avg + q) dvs``, with
    ``s_avg`` the mean of the rotated old and the new deviator (the fluid's viscous
    deviator is a rate, so it uses the new one: dissipation is ``2 eta dev(D):dev(D) dt``),
    ``dvs = 1/rho_new - 1/rho_old = dv/rho_old`` the exact change of specific volume and
    ``v_mid`` the mean specific volume (so that a jump onto the Hugoniot in one step gains
    the Rankine-Hugoniot energy exactly). ``q`` (stored, not added to the stress) uses the
    sound speed at the new density and old pressure.

    Inlined into its caller by LLVM (see the module's notes on speed). Every column is read before
    and written after :func:`material_step`, outside any branch; a failed update writes
    back the values it read.
    """
    return update_stress_columns(p, code, prm, dt, h, Lg, mat.stress, mat.F, mat.rho,
                                 mat.eps_p, mat.e_int, mat.temp, mat.q, mat.damage,
                                 mat.w_p)


@njit(cache=True, forceinline=True)
def update_stress_columns(p, code, prm, dt, h, Lg, stress, F, rho, eps_p, e_int, temp, q,
                          damage, w_p):
    """:func:`update_stress` on the material columns themselves (the particle loops
    unpack the record once, outside the loop)."""
    prm_t = (prm[0], prm[1], prm[2], prm[3], prm[4], prm[5], prm[6], prm[7], prm[8],
             prm[9], prm[10], prm[11], prm[12], prm[13], prm[14], prm[15], prm[16],
             prm[17], prm[18], prm[19], prm[20], prm[21], prm[22], prm[23], prm[24],
             prm[25], prm[26], prm[27], prm[28], prm[29], prm[30])
    lg = (Lg[0, 0], Lg[0, 1], Lg[0, 2], Lg[1, 0], Lg[1, 1], Lg[1, 2],
          Lg[2, 0], Lg[2, 1], Lg[2, 2])
    sig_old = (stress[p, 0], stress[p, 1], stress[p, 2], stress[p, 3], stress[p, 4],
               stress[p, 5])
    f_old = (F[p, 0], F[p, 1], F[p, 2], F[p, 3], F[p, 4], F[p, 5], F[p, 6], F[p, 7],
             F[p, 8])
    if code == JOHNSON_COOK or code == J2_PLASTIC:
        c, sig, f, rho_new, eps_new, e_new, temp_new, q_new, dam_new, wp_new = material_step(
            JOHNSON_COOK, prm_t, dt, h, lg, sig_old, f_old, rho[p], eps_p[p], e_int[p],
            temp[p], q[p], damage[p], w_p[p])
    else:
        c, sig, f, rho_new, eps_new, e_new, temp_new, q_new, dam_new, wp_new = material_step(
            code, prm_t, dt, h, lg, sig_old, f_old, rho[p], eps_p[p], e_int[p], temp[p], q[p],
            damage[p], w_p[p])
    stress[p, 0], stress[p, 1], stress[p, 2] = sig[0], sig[1], sig[2]
    stress[p, 3], stress[p, 4], stress[p, 5] = sig[3], sig[4], sig[5]
    F[p, 0], F[p, 1], F[p, 2] = f[0], f[1], f[2]
    F[p, 3], F[p, 4], F[p, 5] = f[3], f[4], f[5]
    F[p, 6], F[p, 7], F[p, 8] = f[6], f[7], f[8]
    rho[p] = rho_new
    eps_p[p] = eps_new
    e_int[p] = e_new
    temp[p] = temp_new
    q[p] = q_new
    damage[p] = dam_new
    w_p[p] = wp_new
    return c
