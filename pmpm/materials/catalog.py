"""The material models a case may name, their parameters, units and defaults.

Plain Python, no Numba: the case layer validates against ``MODELS`` and the solver packs
a validated material into a parameter row with :func:`pack`. Units follow the case's
consistent system; the names below use the examples' mm, ms, g (stress in MPa).

Elastic constants: give any two of ``E``, ``nu``, ``K``, ``G`` (solids). Optional blocks
on any model but ``rigid``: ``eos`` (``{type: mie_gruneisen, c0, s, gamma0}`` or
``{type: linear, c0}``), ``bulk_viscosity`` (``{linear, quadratic}``), and on the
plastic models ``eps_fail`` (seed 001 Sec. 5.3) or a ``damage`` model
(``{model: johnson_cook, d1, d2, d3, d4, d5, spall_pressure}``, :data:`DAMAGE_MODELS`).
"""
from dataclasses import dataclass, field

import numpy as np

from . import layout as L


@dataclass(frozen=True)
class Param:
    slot: int
    unit: str
    doc: str
    default: float | None = None          # None: required


@dataclass(frozen=True)
class Model:
    name: str
    code: int
    doc: str
    params: dict = field(default_factory=dict)
    elastic: bool = True                  # needs two elastic constants
    plastic: bool = False                 # accepts eps_fail
    needs_eos: bool = False


DENSITY = {"density": Param(L.RHO0, "g/mm^3", "initial density")}
HARDENING_POWER = {
    "A": Param(L.A, "MPa", "initial yield stress"),
    "B": Param(L.B, "MPa", "hardening modulus"),
    "n": Param(L.N, "-", "hardening exponent"),
}
THERMAL = {
    "C": Param(L.C, "-", "strain-rate constant", 0.0),
    "eps_dot0": Param(L.EPS_DOT0, "1/ms", "reference plastic strain rate (1/s = 1e-3/ms)", 1e-3),
    "m": Param(L.M, "-", "thermal softening exponent (0: none)", 0.0),
    "T_room": Param(L.T_ROOM, "K", "room (initial) temperature", 293.0),
    "T_melt": Param(L.T_MELT, "K", "melting temperature", 1.0e30),
    "cp": Param(L.CP, "mJ/(g K)", "specific heat (= J/(kg K))", 0.0),
    "chi": Param(L.CHI, "-", "Taylor-Quinney factor (plastic work to heat)", 0.9),
}

MODELS = {m.name: m for m in [
    Model("elastic", L.ELASTIC, "linear (hypo)elastic, Jaumann rate", dict(DENSITY)),
    Model("neo_hookean", L.NEO_HOOKEAN, "compressible Neo-Hookean from the deformation gradient",
          dict(DENSITY)),
    Model("j2_linear", L.J2_PLASTIC, "J2 plasticity, linear isotropic hardening",
          {**DENSITY, "yield_stress": Param(L.A, "MPa", "initial yield stress"),
           "tangent_modulus": Param(L.B, "MPa", "slope of the uniaxial stress-strain curve "
                                    "after yield (0: perfectly plastic)", 0.0)},
          plastic=True),
    Model("j2_power", L.J2_PLASTIC, "J2 plasticity, sigma_y = A + B eps_p^n",
          {**DENSITY, **HARDENING_POWER}, plastic=True),
    Model("johnson_cook", L.JOHNSON_COOK,
          "Johnson-Cook: (A + B eps_p^n)(1 + C ln(eps_dot_p/eps_dot0))(1 - T*^m), adiabatic heating",
          {**DENSITY, **HARDENING_POWER, **THERMAL}, plastic=True),
    Model("fluid", L.FLUID, "no strength: pressure from the EOS, optional viscosity and tension cutoff",
          {**DENSITY,
           "viscosity": Param(L.VISCOSITY, "MPa ms", "dynamic viscosity", 0.0),
           "tension_cutoff": Param(L.TENSION_CUTOFF, "MPa", "largest tension the fluid sustains", 0.0)},
          elastic=False, needs_eos=True),
    Model("rigid", L.RIGID, "rigid body moving with its prescribed velocity (free, under "
          "contact and gravity, in the axes its rigid.free names)",
          dict(DENSITY), elastic=False),
]}

EOS_MODELS = {
    "mie_gruneisen": (L.EOS_MIE_GRUNEISEN, {
        "c0": Param(L.EOS_C0, "mm/ms", "bulk sound speed (= m/s)"),
        "s": Param(L.EOS_S, "-", "slope of the shock-particle velocity line"),
        "gamma0": Param(L.EOS_GAMMA0, "-", "Grueneisen coefficient"),
    }),
    "linear": (L.EOS_LINEAR, {
        "c0": Param(L.EOS_C0, "mm/ms", "sound speed: p = rho0 c0^2 (rho/rho0 - 1)"),
    }),
}
DAMAGE_MODELS = {
    "johnson_cook": (L.DAMAGE_JOHNSON_COOK, {
        "d1": Param(L.D1, "-", "fracture strain constant D1 of eps_f = [D1 + D2 exp(D3 "
                    "sigma*)][1 + D4 ln max(eps_dot_p/eps_dot0, 1)][1 + D5 T*]"),
        "d2": Param(L.D2, "-", "fracture strain constant D2 (factor of exp(D3 sigma*))"),
        "d3": Param(L.D3, "-", "fracture strain constant D3, the triaxiality exponent; "
                    "sigma* = -p / sigma_vm with p the pressure (positive in compression), "
                    "so sigma* > 0 in tension (usually D3 < 0)"),
        "d4": Param(L.D4, "-", "fracture strain constant D4, the strain-rate term "
                    "(rate over the material's eps_dot0; johnson_cook models only)", 0.0),
        "d5": Param(L.D5, "-", "fracture strain constant D5, the temperature term "
                    "(homologous T* of the material's T_room, T_melt; johnson_cook models "
                    "only)", 0.0),
        "spall_pressure": Param(L.SPALL, "MPa", "spall cut-off: a tension (negative "
                                "pressure) beyond -spall_pressure fails the point "
                                "(0: none)", 0.0),
    }),
}
BULK_VISCOSITY = {
    "linear": Param(L.Q_LINEAR, "-", "linear coefficient", 0.0),
    "quadratic": Param(L.Q_QUADRATIC, "-", "quadratic coefficient", 0.0),
}
ELASTIC_CONSTANTS = ("E", "nu", "K", "G")


def elastic_from_any_two(given):
    """Return (E, nu, K, G) from any two of them in ``given`` (a dict)."""
    E, nu, K, G = (given.get(k) for k in ELASTIC_CONSTANTS)
    if E is not None and nu is not None:
        K, G = E / (3 * (1 - 2 * nu)) if nu < 0.5 else float("inf"), E / (2 * (1 + nu))
    elif K is not None and G is not None:
        E, nu = 9 * K * G / (3 * K + G), (3 * K - 2 * G) / (2 * (3 * K + G))
    elif E is not None and G is not None:
        nu = E / (2 * G) - 1
        K = E / (3 * (1 - 2 * nu))
    elif E is not None and K is not None:
        nu = (3 * K - E) / (6 * K)
        G = E / (2 * (1 + nu))
    elif nu is not None and G is not None:
        E = 2 * G * (1 + nu)
        K = E / (3 * (1 - 2 * nu))
    elif nu is not None and K is not None:
        E = 3 * K * (1 - 2 * nu)
        G = E / (2 * (1 + nu))
    return E, nu, K, G


def pack(material):
    """Pack a validated material dict into (model code, float64 row of N_SLOTS)."""
    model = MODELS[material["model"]]
    row = np.zeros(L.N_SLOTS)
    for name, p in model.params.items():
        row[p.slot] = material.get(name, p.default)
    if model.elastic:
        row[L.E], row[L.NU], row[L.K], row[L.G] = elastic_from_any_two(material)
    if model.name == "j2_linear":
        _tangent_to_plastic_modulus(row)
    eos = material.get("eos")
    if eos:
        code, params = EOS_MODELS[eos["type"]]
        row[L.EOS_TYPE] = code
        for name, p in params.items():
            row[p.slot] = eos[name]
    for name, p in BULK_VISCOSITY.items():
        row[p.slot] = (material.get("bulk_viscosity") or {}).get(name, p.default)
    row[L.EPS_FAIL] = material.get("eps_fail", 0.0) or 0.0
    damage = material.get("damage")
    if damage:
        code, params = DAMAGE_MODELS[damage["model"]]
        row[L.DAMAGE] = code
        for name, p in params.items():
            row[p.slot] = damage.get(name, p.default)
    return model.code, row


def _tangent_to_plastic_modulus(row):
    """j2_linear stores the tangent modulus E_t in slot B; the kernel wants the plastic
    modulus H = E E_t / (E - E_t) with exponent n = 1."""
    Et, E = row[L.B], row[L.E]
    row[L.B] = E * Et / (E - Et)
    row[L.N] = 1.0
