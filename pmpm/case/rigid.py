"""The ``rigid:`` key of a body: which translation components of a rigid body are free
(move under contact impulses and gravity) rather than prescribed by its initial velocity.

A body of a `rigid` material moves with its initial velocity unless ``rigid.free`` names
axes; in those its velocity follows the contact impulses on it and gravity, its mass
being the body's. It does not rotate. An FEM body takes the impulses of its surface or
grid coupling (pmpm.solver.rigid_motion); a particle body those of grid contact
(pmpm.solver.rigid_particles), so it needs ``contact.method`` 1 or 2.
"""
from .errors import join
from .fields import Field, choice, list_of, valid

AXIS_NAMES = ("x", "y", "z")
RIGID = {
    "free": Field(list_of(choice(AXIS_NAMES, "axis"), 0, "axis"), [],
                  doc="the translation components of a body of a `rigid` material that "
                      "follow the contact impulses on it and gravity, e.g. [z] (a falling "
                      "wedge); the others keep the initial velocity. It does not rotate, "
                      "and the grid's faces do not hold it. An FEM body takes the impulses "
                      "of its surface or grid coupling; a particle body those of grid "
                      "contact, which it needs (`contact.method` 1 or 2: without it its "
                      "particles would share one nodal field with the others', whose "
                      "push is not measured, so it is refused); within a step the other "
                      "bodies stop against its velocity, then it takes what they took, "
                      "which suits a body heavier than the material it meets in a step. A "
                      "rigid particle body meets FEM bodies by grid coupling only. The "
                      "initial velocity must be uniform (numbers)"),
}


def check_free_rigid(case, problems):
    """A body with ``rigid.free`` must be of a rigid material, with a uniform initial
    velocity, and an FEM body or a particle body with grid contact."""
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
        if valid(body, "method") and body["method"] != "fem" and \
                grid_contact_method(case) == 0:
            problems.add(path, "a free rigid particle body needs grid contact (contact."
                         "method 1 or 2): with contact.method none its particles share "
                         "one nodal field with the other bodies', and the impulses that "
                         "would move it are not measured")
        if valid(body, "velocity") and any(isinstance(c, str) for c in body["velocity"]):
            problems.add(path, "a free rigid body needs a uniform initial velocity: give "
                         "bodies[{}].velocity as numbers, not expressions".format(i))


def grid_contact_method(case):
    """``contact.method`` of the case (None when it did not validate)."""
    contact = case.get("contact")
    return contact.get("method") if isinstance(contact, dict) and valid(contact, "method") \
        else None
