"""Validation of the ``materials:`` section against the material catalog.

The catalog (``pmpm.materials.catalog``) says which models exist, which parameters each
takes and their defaults; this module adds the physical ranges and the rules on elastic
constants (exactly two of E, nu, K, G), ``eos``, ``bulk_viscosity``, ``eps_fail`` and
``damage``.
"""
from pmpm.materials import catalog

from .errors import join
from .fields import (INVALID, OMIT, REQUIRED, Field, NamedItems, Tagged, TaggedByModel,
                     at_least, at_most, between, choice, greater, mapping, number,
                     read_mapping, valid)

# Physical range of each named parameter (catalog names); names not listed: any number.
PARAM_CHECKS = {
    "density": [greater(0)], "E": [greater(0)], "G": [greater(0)], "K": [greater(0)],
    "nu": [between(-1.0, 0.5)], "A": [at_least(0)], "B": [at_least(0)], "n": [greater(0)],
    "C": [at_least(0)], "eps_dot0": [greater(0)], "m": [at_least(0)],
    "T_room": [greater(0)], "T_melt": [greater(0)], "cp": [at_least(0)],
    "chi": [at_least(0), at_most(1)], "yield_stress": [greater(0)],
    "tangent_modulus": [at_least(0)], "viscosity": [at_least(0)],
    "tension_cutoff": [at_least(0)], "c0": [greater(0)], "s": [at_least(0)],
    "gamma0": [at_least(0)], "linear": [at_least(0)], "quadratic": [at_least(0)],
    "eps_fail": [at_least(0)], "spall_pressure": [at_least(0)],
}
ELASTIC = {"E": ("MPa", "Young's modulus"), "nu": ("1", "Poisson's ratio"),     # unit, doc
           "K": ("MPa", "bulk modulus"), "G": ("MPa", "shear modulus")}
TWO_OF = "; give exactly two of E, nu, K, G (the solver derives the others)"


def _param_fields(params):
    """Fields of catalog parameters (catalog default None: required; unit "-": "1")."""
    return {name: Field(number(*PARAM_CHECKS.get(name, [])), _default(p.default),
                        "1" if p.unit == "-" else p.unit, p.doc)
            for name, p in params.items()}


def _default(default):
    return REQUIRED if default is None else float(default)


MODEL = Field(choice(catalog.MODELS, "model"), doc="the material model (below)")
ELASTIC_FIELDS = {name: Field(number(*PARAM_CHECKS[name]), OMIT, ELASTIC[name][0],
                              ELASTIC[name][1] + TWO_OF)
                  for name in catalog.ELASTIC_CONSTANTS}
EOS = Tagged({name: _param_fields(params) for name, (_, params) in catalog.EOS_MODELS.items()},
             "eos type", {},
             {"mie_gruneisen": "Mie-Grueneisen, with the Hugoniot of a linear shock-particle "
                               "velocity relation U_s = c0 + s u_p",
              "linear": "linear in the density: p = rho0 c0^2 (rho/rho0 - 1)"})
OPTIONAL_BLOCKS = {
    "eos": Field(EOS, OMIT, doc="equation of state for the pressure (required for fluid); "
                                "without it the pressure is hypoelastic from K"),
    "bulk_viscosity": Field(mapping(_param_fields(catalog.BULK_VISCOSITY)), OMIT,
                            doc="artificial bulk viscosity for shocks"),
}
EPS_FAIL = Field(number(*PARAM_CHECKS["eps_fail"]), OMIT, "1",
                 "equivalent plastic strain at failure (0: never); the failed point keeps "
                 "no deviatoric stress but keeps its pressure, tension included (seed 001 "
                 "Sec. 5.3)")
DAMAGE = Field(TaggedByModel({name: _param_fields(params)
                              for name, (_, params) in catalog.DAMAGE_MODELS.items()},
                             "damage model", {},
                             {"johnson_cook": "Johnson-Cook (1985) cumulative damage: D += "
                              "d eps_p / eps_f per step (sigma* from the start-of-step "
                              "pressure and the step's flow stress, the plastic strain "
                              "rate of the step, T* of the start-of-step temperature); "
                              "D >= 1 fails the point, which then keeps no deviatoric "
                              "stress and no tension (pressure >= 0)"}),
               OMIT, doc="damage and failure model (instead of eps_fail); the damage D "
                         "is the particle and element column `damage`")
#: damage constants that need a johnson_cook material's eps_dot0 or T_room, T_melt
DAMAGE_NEEDS_JC = {"d4": "a reference strain rate (eps_dot0)",
                   "d5": "a homologous temperature (T_room, T_melt)"}


def read_material(raw, path, problems):
    """One validated material dict (model params with defaults filled)."""
    if not isinstance(raw, dict):
        problems.add(path, "expected a mapping with a 'model' key")
        return INVALID
    model_name = read_mapping({"model": raw.get("model")}, path, {"model": MODEL}, problems)
    if model_name is INVALID or model_name["model"] is INVALID:
        return INVALID
    model = catalog.MODELS[model_name["model"]]
    material = read_mapping(raw, path, material_fields(model), problems)
    if material is not INVALID:
        check_material(material, model, path, problems)
    return material


def material_fields(model):
    """The field table of a material of ``model`` (a catalog.Model)."""
    fields = {"model": MODEL, **_param_fields(model.params)}
    if model.elastic:
        fields.update(ELASTIC_FIELDS)
    if model.name != "rigid":
        fields.update(OPTIONAL_BLOCKS)
    if model.plastic:
        fields["eps_fail"] = EPS_FAIL
        fields["damage"] = DAMAGE
    return fields


class MaterialReader:
    """One material: its ``model`` picks the field table (``material_fields``); the same
    interface as ``Tagged`` for the reference."""
    tag = "model"
    variants = catalog.MODELS
    common = {}

    def __call__(self, raw, path, problems):
        return read_material(raw, path, problems)

    def fields_of(self, kind):
        return material_fields(catalog.MODELS[kind])

    def variant_doc(self, kind):
        return catalog.MODELS[kind].doc

    def kind(self):
        return "mapping with `model`"


MATERIALS = NamedItems(MaterialReader(), "material", "expected a mapping of material name: "
                       "{model: ..., ...} with at least one material")


def check_material(material, model, path, problems):
    """Checks that involve more than one key of a material."""
    if model.elastic:
        _check_elastic(material, model, path, problems)
    if model.needs_eos and "eos" not in material:
        problems.add(join(path, "eos"), f"missing (model {model.name!r} takes its pressure "
                     "from an equation of state: " + " or ".join(catalog.EOS_MODELS) + ")")
    if valid(material, "T_melt", "T_room") and material["T_melt"] <= material["T_room"]:
        problems.add(join(path, "T_melt"), f"must be > T_room = {material['T_room']:g}")
    if valid(material, "damage"):
        _check_damage(material, model, path, problems)


def _check_damage(material, model, path, problems):
    """A damage model replaces eps_fail, and its rate and temperature terms need the
    johnson_cook model's eps_dot0 and T_room, T_melt."""
    if material.get("eps_fail"):
        problems.add(join(path, "damage"), "give either eps_fail or damage, not both "
                     "(the damage model decides failure)")
    if model.name == "johnson_cook":
        return
    for key, what in DAMAGE_NEEDS_JC.items():
        if valid(material["damage"], key) and material["damage"][key] != 0:
            problems.add(join(join(path, "damage"), key), f"must be 0 with model "
                         f"{model.name!r}: it needs {what}, which only model "
                         "'johnson_cook' has")


def _check_elastic(material, model, path, problems):
    given = [k for k in catalog.ELASTIC_CONSTANTS if k in material]
    if len(given) != 2:
        got = ", ".join(given) if given else "none"
        problems.add(path, f"model {model.name!r} needs exactly two of E, nu, K, G; "
                     f"got {len(given)} ({got})")
        return
    if not valid(material, *given):
        return
    pair = " and ".join(f"{k} = {material[k]:g}" for k in given)
    try:
        E, nu, K, G = catalog.elastic_from_any_two({k: material[k] for k in given})
    except ZeroDivisionError:
        problems.add(path, f"{pair} give nu = 0.5 (incompressible); need -1 < nu < 0.5")
        return
    if not (-1 < nu < 0.5 and E > 0 and G > 0):
        problems.add(path, f"{pair} give nu = {nu:g}; need -1 < nu < 0.5")
    elif valid(material, "tangent_modulus") and material["tangent_modulus"] >= E:
        problems.add(join(path, "tangent_modulus"), f"must be < E = {E:g}")
