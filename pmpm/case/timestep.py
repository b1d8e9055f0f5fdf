"""``time.cfl: auto``: the Courant number the validation matrix supports for the case
(docs/validation/defaults.md, "The time step").

At 0.8 every row of the matrix keeps its answers within tolerance, with 0.63 times the
steps of 0.5, as long as the case has particle bodies alone under the 27-node shapes,
without contact between them, failure or bulk viscosity. Under the hats the particles'
cell crossings cost energy in proportion to the step (the Taylor bar: +0.15 % at 0.5,
+3.7 % at 0.8). Where bodies meet (the rings' drift, particle-to-surface
contact with an FEM body), where points fail (the perforations) and where shocks are
smeared by bulk viscosity (the energy error doubles with the step: the planar shock, the
copper block) the answers hold at 0.5, so auto takes 0.5 there.
"""
from .fields import INVALID, at_most, greater, number, valid

AUTO = "auto"
#: the Courant number auto takes for particle bodies without contact, failure or shocks
QUICK_CFL = 0.8
#: the one it takes for everything else
SAFE_CFL = 0.5
#: the shape functions that keep the energy at 0.8
QUICK_SHAPES = ("gimp", "bspline")
#: the solid models (the matrix's rows at 0.8 are elastic and Johnson-Cook; the J2 models
#: share Johnson-Cook's return map, and the neo-Hookean bar keeps the elastic one's
#: energy at 0.8: docs/validation/defaults.md; no row runs the fluid or the rigid model)
QUICK_MODELS = ("elastic", "neo_hookean", "j2_linear", "j2_power", "johnson_cook")
CFL_DOC = ("Courant number: the fraction of the stable time step (seed 001 Eq. 35) that "
           "is taken, or `auto` (the default): 0.8 for particle bodies of solid materials "
           "under gimp or bspline shapes without contact (between bodies or on a frictional "
           "grid face), failure (eps_fail, damage) or bulk viscosity, "
           "where the validation matrix keeps every answer with 0.63 times the steps of "
           "0.5; 0.5 for everything else (the hats, contact between bodies, FEM bodies, "
           "failure and shocks gain energy or drift at 0.8: docs/validation/defaults.md). The start "
           "line says which was taken")


def read_cfl(raw, path, problems):
    """A number in (0, 1], or auto (the default, :func:`resolve_step_default`)."""
    if str(raw).strip().lower() == AUTO:
        return AUTO
    if isinstance(raw, str):
        problems.add(path, f"expected a number in (0, 1] or auto, got {raw!r}")
        return INVALID
    return number(greater(0), at_most(1))(raw, path, problems)


def resolve_step_default(case):
    """Turn ``time.cfl`` left at ``auto`` into :data:`QUICK_CFL` or :data:`SAFE_CFL`.
    Idempotent: a resolved case validates to itself."""
    time = case.get("time")
    if isinstance(time, dict) and time.get("cfl") == AUTO:
        time["cfl"] = QUICK_CFL if takes_the_quick_step(case) else SAFE_CFL


def takes_the_quick_step(case):
    """Whether the case has particle bodies alone, 27-node shapes, one velocity field
    (no grid contact), no friction on the grid's faces and materials that neither fail
    nor carry bulk viscosity."""
    bodies, contact = case.get("bodies"), case.get("contact")
    materials, grid = case.get("materials"), case.get("grid")
    if not isinstance(grid, dict) or grid.get("shape_functions") not in QUICK_SHAPES:
        return False
    if any(isinstance(mu, (int, float)) and mu > 0
           for mu in (grid.get("friction") or {}).values()):
        return False                        # a face that rubs, as bodies that meet
    if not isinstance(bodies, list) or not isinstance(materials, dict):
        return False
    if not isinstance(contact, dict) or (contact.get("method") and len(bodies) > 1):
        return False                        # bodies meet (one body meets nothing)
    if any(not isinstance(b, dict) or b.get("method", "particles") != "particles"
           for b in bodies):
        return False
    used = {b.get("material") for b in bodies}
    return all(isinstance(materials.get(name), dict) and quick_material(materials[name])
               for name in used)


def quick_material(material):
    """A solid model without failure or bulk viscosity."""
    if material.get("model") not in QUICK_MODELS:
        return False
    if material.get("damage") or material.get("bulk_viscosity"):
        return False
    eps_fail = material.get("eps_fail")
    return not (valid(material, "eps_fail") and eps_fail is not None and eps_fail > 0)
