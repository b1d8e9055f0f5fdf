"""The ``rigid:`` key of a body: which translation components of a rigid body are free
(move under contact impulses and gravity) rather than prescribed by its initial velocity.

A body of a `rigid` material moves with its initial velocity unless ``rigid.free`` names
axes; in those its velocity follows the contact impulses on it and gravity, its mass
being the body's (pmpm.solver.rigid_motion). It does not rotate. Free rigid bodies are
FEM bodies for now (their surface or grid coupling gives the impulses); a free rigid
particle body is refused.
"""
from .errors import join
from .fields import Field, choice, list_of, valid

AXIS_NAMES = ("x", "y", "z")
RIGID = {
    "free": Field(list_of(choice(AXIS_NAMES, "axis"), 0, "axis"), [],
                  doc="the translation components of a body of a `rigid` material that "
                      "follow the contact impulses on it and gravity, e.g. [z] (a falling "
                      "wedge); the others keep the initial velocity. It does not rotate. "
                      "FEM bodies only (surface or grid coupling); the initial velocity "
                      "must be uniform (numbers)"),
}


def check_free_rigid(case, problems):
    """A body with ``rigid.free`` must be an FEM body of a rigid material with a uniform
    initial velocity."""
    bodies = case["bodies"] if isinstance(case["bodies"], list) else []
    materials = case["materials"] if isinstance(case["materials"], dict) else {}
    for i, body in enumerate(bodies):
        if not isinstance(body, dict) or not valid(body, "rigid") or \
                not body["rigid"].get("free"):
            continue
        path = join(join(join("bodies", i), "rigid"), "free")
        material = materials.get(body.get("material"))
        if isinstance(material, dict) and material.get("model") != "rigid":
            problems.add(path, f"body '{body.get('name')}' has material "
                         f"'{body.get('material')}' (model {material.get('model')}), not a "
                         f"rigid one: only a rigid body can be free")
        if valid(body, "method") and body["method"] != "fem":
            problems.add(path, "a free rigid body must be an FEM body (method: fem) for "
                         "now; rigid particle bodies move with their initial velocity")
        if valid(body, "velocity") and any(isinstance(c, str) for c in body["velocity"]):
            problems.add(path, "a free rigid body needs a uniform initial velocity: give "
                         "bodies[{}].velocity as numbers, not expressions".format(i))
