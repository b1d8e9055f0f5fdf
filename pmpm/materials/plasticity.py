"""J2 (von Mises) plasticity with isotropic hardening, rate and thermal terms (Numba).

Flow stress, seed 001 Eqs. 37 and 39 and seed 004 Sec. 4.2::

    sigma_y = (A + B eps_p^n) (1 + C ln max(eps_dot_p / eps_dot0, 1)) (1 - T*^m)

``J2_PLASTIC`` rows leave C and m at 0, so both factors are 1 and the same return map
serves j2_linear, j2_power and johnson_cook.
"""
import math

from numba import njit

from .layout import A, B, C, EPS_DOT0, M, N, T_MELT, T_ROOM
from .tensors import fdiv, scale, von_mises

MAX_NEWTON = 50
NEWTON_RTOL = 1e-11


@njit(cache=True, forceinline=True)
def hardening(a, b, n, eps):
    """Strain-hardening term ``a + b eps^n``."""
    if eps <= 0.0:
        return a
    if n == 1.0:
        return a + b * eps
    return a + b * eps ** n


@njit(cache=True, forceinline=True)
def hardening_slope_in_t(b, n, k, dlam, eps):
    """Slope of ``b eps^n`` with respect to ``t``, where ``dlam = t^k`` and ``eps`` is the
    plastic strain after the increment.

    Notes
    -----
    With ``k = 1/n`` (n < 1) the slope is ``b (dlam/eps)^(1-n)``, bounded by ``b`` even at
    ``eps = 0`` where ``d(eps^n)/d eps`` is infinite; that bound is the reason for the
    change of variable. With ``k = 1`` it is the ordinary ``n b eps^(n-1)``.
    """
    if b == 0.0:
        return 0.0
    if k != 1.0:
        if eps <= 0.0:
            return b
        return b * fdiv(dlam, eps) ** (1.0 - n)
    if n == 1.0:
        return b
    if eps <= 0.0:
        return 0.0
    return n * b * eps ** (n - 1.0)


@njit(cache=True, forceinline=True)
def rate_factor(c, eps_dot0, dlam, dt):
    """Johnson-Cook rate factor ``1 + c ln max(eps_dot_p/eps_dot0, 1)``.

    The plastic strain rate is ``eps_dot_p = dlam / dt``, the plastic strain increment of
    the step over the step (seed 004 Sec. 4.2), so the factor is implicit in ``dlam``.
    """
    if c == 0.0 or eps_dot0 <= 0.0 or dt <= 0.0:
        return 1.0
    ratio = fdiv(dlam, dt * eps_dot0)
    if ratio <= 1.0:
        return 1.0
    return 1.0 + c * math.log(ratio)


@njit(cache=True, forceinline=True)
def thermal_factor(m, temp, t_room, t_melt):
    """Johnson-Cook thermal softening ``1 - T*^m``, ``T* = (T - T_room)/(T_melt - T_room)``.

    ``T*`` is clipped to [0, 1]; ``m = 0`` (or ``T_melt <= T_room``) means no softening
    (not ``1 - T*^0 = 0``).
    """
    if m == 0.0 or t_melt <= t_room:
        return 1.0
    t_star = min(max(fdiv(temp - t_room, t_melt - t_room), 0.0), 1.0)
    return 1.0 - t_star ** m


@njit(cache=True, forceinline=True)
def flow_stress(dlam, eps_p, dt, a, b, n, c, eps_dot0, theta):
    """Flow stress after a plastic increment ``dlam`` at the rate ``dlam/dt``.

    ``theta`` is the thermal factor, held at its start-of-step value.
    """
    return (theta * hardening(a, b, n, eps_p + dlam)
            * rate_factor(c, eps_dot0, dlam, dt))


@njit(cache=True, forceinline=True)
def flow_stress_slope_in_t(t, k, eps_p, dt, a, b, n, c, eps_dot0, theta):
    """``d sigma_y / dt`` for ``dlam = t^k`` (see :func:`plastic_multiplier`)."""
    dlam = t ** k
    eps = eps_p + dlam
    rate = rate_factor(c, eps_dot0, dlam, dt)
    drate = fdiv(c * k, t) if rate > 1.0 else 0.0     # d(c ln(t^k / (dt eps_dot0)))/dt
    return theta * (hardening_slope_in_t(b, n, k, dlam, eps) * rate
                    + hardening(a, b, n, eps) * drate)


@njit(cache=True, forceinline=True)
def plastic_multiplier(q_trial, g, eps_p, dt, a, b, n, c, eps_dot0, theta):
    """Equivalent plastic strain increment of a radial return.

    Solves ``r(dlam) = q_trial - 3 g dlam - sigma_y(eps_p + dlam, dlam/dt) = 0``.

    Parameters
    ----------
    q_trial : float
        Von Mises stress of the elastic trial deviator.
    g : float
        Shear modulus.
    eps_p, dt : float
        Plastic strain at the start of the step, time step.
    a, b, n, c, eps_dot0, theta : float
        Flow stress constants and thermal factor, see :func:`flow_stress`.

    Returns
    -------
    dlam : float
        Plastic strain increment (0 for an elastic step).
    sigma_y : float
        Flow stress at the end of the step.
    converged : bool
        False when the iteration did not converge in ``MAX_NEWTON`` iterations.

    Notes
    -----
    Linear hardening without rate term (``n = 1`` or ``b = 0``, ``c = 0``) has the closed
    form ``dlam = (q_trial - sigma_y0)/(3g + theta b)``. Otherwise a safeguarded Newton
    iteration solves for ``t`` with ``dlam = t^k``, ``k = 1/n`` when ``n < 1`` (else 1):
    in ``t`` the hardening slope is bounded, whereas ``d(eps^n)/d eps`` is infinite at
    ``eps = 0``, which would stall Newton on the first plastic step of a virgin particle.
    ``sigma_y`` does not decrease with ``dlam`` (b, c >= 0), so the root lies in
    ``[0, (q_trial - sigma_y0)/(3g)]`` (the perfectly plastic increment, where ``r <= 0``).
    Newton starts at that upper bound; each iterate narrows the bracket by the sign of
    ``r``, and a step that leaves the bracket, or that is not half the one before it
    (slow progress, e.g. at the kink of the rate term), is replaced by bisection. Converged when
    ``|r| <= NEWTON_RTOL q_trial`` or when the bracket has shrunk to round-off.
    """
    dlam, sigma_y, _, converged = plastic_increment(q_trial, g, eps_p, dt, a, b, n, c,
                                                    eps_dot0, theta)
    return dlam, sigma_y, converged


@njit(cache=True, forceinline=True)
def plastic_increment(q_trial, g, eps_p, dt, a, b, n, c, eps_dot0, theta):
    """:func:`plastic_multiplier` and the radial-return factor of the stress kernel.

    Returns
    -------
    dlam, sigma_y, converged
        As :func:`plastic_multiplier`.
    ratio : float
        ``sigma_y / q_trial``, the factor that scales the trial deviator back onto the
        yield surface when the step yields (1 otherwise). For the closed form it is
        evaluated as ``(3g sigma_y0 + theta b q_trial) / ((3g + theta b) q_trial)``, equal
        up to round-off: one division after the square root of ``q_trial`` instead of two
        in a row, which shortens the kernel's dependency chain.
    """
    tol = NEWTON_RTOL * q_trial
    sy0 = theta * hardening(a, b, n, eps_p)            # flow_stress at dlam = 0
    if q_trial - sy0 <= tol:
        return 0.0, sy0, 1.0, True
    if c == 0.0 and (n == 1.0 or b == 0.0):
        slope = theta * b if n == 1.0 else 0.0
        g3 = 3.0 * g
        dlam = fdiv(q_trial - sy0, g3 + slope)
        ratio = fdiv(g3 * sy0 + slope * q_trial, (g3 + slope) * q_trial)
        return dlam, sy0 + slope * dlam, ratio, dlam >= 0.0
    dlam, sigma_y, converged = newton_multiplier(q_trial, g, eps_p, dt, a, b, n, c, eps_dot0,
                                                 theta, sy0, tol)
    return dlam, sigma_y, fdiv(sigma_y, q_trial), converged


@njit(cache=True, forceinline=True)
def newton_multiplier(q_trial, g, eps_p, dt, a, b, n, c, eps_dot0, theta, sy0, tol):
    """The safeguarded Newton iteration of :func:`plastic_multiplier`, for a step that yields
    (``q_trial - sy0 > tol``).

    Notes
    -----
    Per iterate, ``dlam = t^k``, the hardening and the rate factor are evaluated once and
    shared by the residual and its slope; with ``k = 1`` (``n >= 1``), ``t^k = t`` and
    ``t^(k-1) = 1`` exactly, so no power is taken for them.
    """
    k = fdiv(1.0, n) if 0.0 < n < 1.0 else 1.0
    unit = k == 1.0
    lo = 0.0
    hi = fdiv(q_trial - sy0, 3.0 * g)
    if not unit:
        hi = hi ** fdiv(1.0, k)
    t = hi
    step = step_before = hi
    for _ in range(MAX_NEWTON):
        dlam = t if unit else t ** k
        eps = eps_p + dlam
        hard = hardening(a, b, n, eps)
        rate = rate_factor(c, eps_dot0, dlam, dt)
        sy = theta * hard * rate
        r = q_trial - 3.0 * g * dlam - sy
        if abs(r) <= tol:
            return dlam, sy, True
        if r > 0.0:
            lo = t
        else:
            hi = t
        if hi - lo <= 4e-16 * hi:                       # root pinned to round-off
            return dlam, sy, True
        drate = fdiv(c * k, t) if rate > 1.0 else 0.0  # d(c ln(t^k / (dt eps_dot0)))/dt
        sy_slope = theta * (hardening_slope_in_t(b, n, k, dlam, eps) * rate + hard * drate)
        slope = 3.0 * g * k * (1.0 if unit else t ** (k - 1.0)) + sy_slope
        newton = fdiv(r, slope) if slope > 0.0 else hi - lo
        step_before, step = step, newton
        if not lo < t + newton < hi or abs(2.0 * newton) > abs(step_before):
            step = 0.5 * (hi - lo)                      # too slow or outside: bisect
            t = lo + step
        else:
            t += newton
    dlam = t if unit else t ** k
    return dlam, flow_stress(dlam, eps_p, dt, a, b, n, c, eps_dot0, theta), False


@njit(cache=True, forceinline=True)
def radial_return(s_trial, q_trial, sigma_y):
    """Scale the trial deviator back onto the yield surface: ``s = s_trial sigma_y/q_trial``."""
    if q_trial <= sigma_y:
        return s_trial
    return scale(s_trial, fdiv(sigma_y, q_trial))


@njit(cache=True)
def return_map(prm, g, s_trial, eps_p, temp, dt):
    """J2 return map of one particle for a packed J2_PLASTIC or JOHNSON_COOK row.

    Parameters
    ----------
    prm : float64[N_SLOTS]
        Packed material row.
    g : float
        Shear modulus.
    s_trial : tuple of 6 float
        Elastic trial deviator.
    eps_p, temp : float
        Equivalent plastic strain and temperature at the start of the step.
    dt : float
        Time step.

    Returns
    -------
    s : tuple of 6 float
        Deviatoric stress on (or inside) the yield surface.
    dlam : float
        Equivalent plastic strain increment.
    sigma_y : float
        Flow stress at the end of the step.
    converged : bool
        False when the scalar equation failed to converge.

    Notes
    -----
    The thermal factor uses the start-of-step temperature (adiabatic heating is applied
    after the step, explicitly).
    """
    theta = thermal_factor(prm[M], temp, prm[T_ROOM], prm[T_MELT])
    q_trial = von_mises(s_trial)
    dlam, sigma_y, ok = plastic_multiplier(q_trial, g, eps_p, dt, prm[A], prm[B], prm[N],
                                           prm[C], prm[EPS_DOT0], theta)
    return radial_return(s_trial, q_trial, sigma_y), dlam, sigma_y, ok
