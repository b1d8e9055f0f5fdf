"""Volumetric response of the material kernels: equations of state and bulk viscosity.

Pressure is positive in compression. ``mu = rho/rho0 - 1`` is the compression and
``E_n = rho0 * e_int`` the internal energy per initial volume (``e_int`` is per mass).
Every EOS here is linear in the internal energy, ``p = a(rho) + b * e_int``, which lets
the stress kernel solve the energy equation of a step in closed form
(:func:`pmpm.materials.kernels.pressure_and_energy`).
"""
import math

from numba import njit

from .layout import (EOS_C0, EOS_GAMMA0, EOS_LINEAR, EOS_MIE_GRUNEISEN, EOS_S, EOS_TYPE,
                     RHO0)
from .tensors import fdiv


@njit(cache=True, forceinline=True)
def mie_gruneisen_reference(mu, rho0, c0, s, gamma0):
    """Mie-Grueneisen pressure at zero internal energy (seed 001 Eq. 38 with E_n = 0).

    Parameters
    ----------
    mu : float
        Compression ``rho/rho0 - 1``.
    rho0, c0, s, gamma0 : float
        Initial density, bulk sound speed, slope of the shock-particle velocity line and
        Grueneisen coefficient.

    Returns
    -------
    float
        The pressure; NaN beyond the limiting compression ``mu >= 1/(s - 1)`` where the
        Hugoniot diverges (the caller then reports a failed update).

    Notes
    -----
    In compression Eq. 38 reads ``rho0 c0^2 mu (1 + mu) / [1 - (s-1) mu]^2 * (1 - gamma mu/2)``
    with the Grueneisen coefficient ``gamma = gamma0 rho0/rho = gamma0/(1 + mu)`` (the usual
    ``gamma rho = const``), so ``(1 + mu)(1 - gamma mu/2) = 1 + mu - gamma0 mu^2/2``. This is
    the Hugoniot pressure referenced form ``p_H (1 - gamma0 eta/2)``, ``eta = 1 - rho0/rho``,
    identical to LS-DYNA's ``*EOS_GRUNEISEN`` with ``a = 0`` and one ``S`` term.
    In tension the linear branch ``rho0 c0^2 mu`` applies.
    """
    if mu <= 0.0:
        return rho0 * c0 * c0 * mu
    den = 1.0 - (s - 1.0) * mu
    if den <= 0.0:
        return math.nan
    return fdiv(rho0 * c0 * c0 * (mu * (1.0 + mu) - 0.5 * gamma0 * mu * mu), den * den)


@njit(cache=True, forceinline=True)
def mie_gruneisen_pressure(mu, e_n, rho0, c0, s, gamma0):
    """Mie-Grueneisen pressure, seed 001 Eq. 38: reference pressure plus ``gamma0 E_n``.

    ``e_n`` is the internal energy per initial volume (``rho0 * e_int``).
    """
    return mie_gruneisen_reference(mu, rho0, c0, s, gamma0) + gamma0 * e_n


@njit(cache=True, forceinline=True)
def mie_gruneisen_tangent(mu, pressure, rho0, c0, s, gamma0):
    """Isentropic slope ``dp/drho`` of the Mie-Grueneisen EOS (the square of a sound speed).

    Notes
    -----
    ``dp/drho = (dp_ref/dmu + gamma0 dE_n/dmu) / rho0`` with ``dE_n/dmu = p/(1 + mu)^2``
    along an isentrope (``dE_n = -p d(rho0/rho)``). For the compressed branch, with
    ``f = mu(1 + mu) - gamma0 mu^2/2`` and ``g = (1 - (s-1) mu)^2``,
    ``dp_ref/dmu = rho0 c0^2 (f' g - f g') / g^2``.
    """
    if mu <= 0.0:
        dref = rho0 * c0 * c0
    else:
        lin = 1.0 - (s - 1.0) * mu
        if lin <= 0.0:
            return math.nan
        f = mu * (1.0 + mu) - 0.5 * gamma0 * mu * mu
        df = 1.0 + 2.0 * mu - gamma0 * mu
        g = lin * lin
        dg = -2.0 * (s - 1.0) * lin
        dref = fdiv(rho0 * c0 * c0 * (df * g - f * dg), g * g)
    return fdiv(dref + fdiv(gamma0 * pressure, (1.0 + mu) * (1.0 + mu)), rho0)


@njit(cache=True, forceinline=True)
def eos_at_density(eos_type, rho, rho0, c0, s, gamma0):
    """Everything of an EOS at density ``rho`` that does not depend on the energy.

    Parameters
    ----------
    eos_type : float
        ``EOS_MIE_GRUNEISEN`` or ``EOS_LINEAR`` (slot ``EOS_TYPE``).
    rho : float
        Current density.
    rho0, c0, s, gamma0 : float
        The row's EOS constants (``s`` and ``gamma0`` unused by the linear EOS).

    Returns
    -------
    a, b : float
        Pressure ``p = a + b * e_int``, the same arithmetic, operation for operation, as
        :func:`eos_pressure_coefficients`.
    kt0, kt1 : float
        ``rho dp/drho = kt0 + kt1 * P`` at pressure ``P`` (the bulk stiffness of the wave
        speed): for Mie-Grueneisen ``kt0 = (rho/rho0) dp_ref/dmu`` and
        ``kt1 = gamma0 rho0/rho``, i.e. ``rho`` times :func:`mie_gruneisen_tangent`
        regrouped (equal up to round-off); for the linear EOS ``kt0 = rho c0^2``, ``kt1 = 0``.

    Notes
    -----
    Shares what the pressure and the tangent have in common (``mu``, ``1 - (s-1) mu``,
    ``mu (1 + mu) - gamma0 mu^2/2``), so the stress kernel evaluates the Hugoniot once per
    step for the pressure and both wave speeds; the stiffness is linear in ``P``, so the
    end-of-step wave speed is a short chain after the pressure (no division).
    """
    r = fdiv(rho, rho0)
    mu = r - 1.0
    rc2 = rho0 * c0 * c0
    if eos_type != EOS_MIE_GRUNEISEN:
        return rc2 * mu, 0.0, rho * (c0 * c0), 0.0
    if mu <= 0.0:
        a = rc2 * mu
        dref = rc2
    else:
        lin = 1.0 - (s - 1.0) * mu
        if lin <= 0.0:
            a = math.nan
            dref = math.nan
        else:
            f = mu * (1.0 + mu) - 0.5 * gamma0 * mu * mu
            df = 1.0 + 2.0 * mu - gamma0 * mu
            g = lin * lin
            dg = -2.0 * (s - 1.0) * lin
            a = fdiv(rc2 * f, g)
            dref = fdiv(rc2 * (df * g - f * dg), g * g)
    return a, gamma0 * rho0, r * dref, fdiv(gamma0, r)


@njit(cache=True)
def eos_pressure_coefficients(prm, rho):
    """``(a, b)`` such that the EOS pressure at density ``rho`` is ``a + b * e_int``.

    Parameters
    ----------
    prm : float64[N_SLOTS]
        Packed material row with ``EOS_TYPE`` != ``EOS_NONE``.
    rho : float
        Current density.

    Returns
    -------
    tuple of 2 float
        Mie-Grueneisen: ``a`` = reference pressure, ``b = gamma0 rho0`` (as
        ``E_n = rho0 e_int``); linear: ``a = rho0 c0^2 mu``, ``b = 0``.
    """
    rho0 = prm[RHO0]
    c0 = prm[EOS_C0]
    mu = fdiv(rho, rho0) - 1.0
    if prm[EOS_TYPE] == EOS_MIE_GRUNEISEN:
        a = mie_gruneisen_reference(mu, rho0, c0, prm[EOS_S], prm[EOS_GAMMA0])
        return a, prm[EOS_GAMMA0] * rho0
    return rho0 * c0 * c0 * mu, 0.0


@njit(cache=True)
def eos_tangent(prm, rho, pressure):
    """Isentropic ``dp/drho`` of the body's EOS at ``rho`` and current ``pressure``."""
    rho0 = prm[RHO0]
    c0 = prm[EOS_C0]
    if prm[EOS_TYPE] == EOS_MIE_GRUNEISEN:
        return mie_gruneisen_tangent(fdiv(rho, rho0) - 1.0, pressure, rho0, c0,
                                     prm[EOS_S], prm[EOS_GAMMA0])
    if prm[EOS_TYPE] == EOS_LINEAR:
        return c0 * c0
    return 0.0


@njit(cache=True, forceinline=True)
def bulk_viscosity(rho, h, c, div, q_linear, q_quadratic):
    """Artificial bulk viscosity pressure (von Neumann-Richtmyer plus a linear term).

    Parameters
    ----------
    rho : float
        Current density.
    h : float
        Characteristic length (the cell size).
    c : float
        Sound speed.
    div : float
        Volumetric strain rate ``tr(D)`` (negative in compression).
    q_linear, q_quadratic : float
        Dimensionless coefficients.

    Returns
    -------
    float
        ``q = rho h (q_quadratic h div^2 - q_linear c div)`` in compression (``div < 0``),
        positive; 0 in expansion. The force kernel uses ``stress - q I``.
    """
    if div >= 0.0:
        return 0.0
    return rho * h * (q_quadratic * h * div * div - q_linear * c * div)
