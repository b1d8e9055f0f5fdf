"""The ``contact:`` section: multi-velocity grid contact (seed 001 Secs. 2-4).

    contact:
      method: 2             # none (one shared velocity field: standard MPM), 1 or 2
      friction: 0.1         # Coulomb coefficient of every pair not listed below
      normal: average       # collinear normals: average (Eq. 10), stiffer, or a body name
      separation: 0.9       # optional: contact only where the bodies are at most 0.9
                            # cells apart at a node (absent or none: the paper's detection)
      release: 0.0          # optional: no contact where the surfaces' gap from particle
                            # positions exceeds 0 cells (absent or none: the paper's rule)
      gap: reach            # how the release rule measures the gap: reach or volume
      coupling: surface     # how FEM bodies meet particle bodies (seed 004): surface
                            # (ICFEMP, Sec. 3) or grid (CFEMP, Sec. 2.4; needs method 1 or 2);
                            # surface: FEM bodies meet each other by node-to-surface contact
      pairs:                # optional: per pair of bodies
        - bodies: [ball, plate]
          friction: 0.0
          normal: ball      # the named body's own normal (Sec. 2.3 choices 1 and 2)
          separation: 0.9
          release: 0.0
          coupling: grid    # a pair of an FEM body and a particle body (two FEM bodies:
                            # surface only)

With method 1 or 2 every body has its own velocity field at nodes that two or more
bodies reach, and every pair of bodies is in contact.
"""
from .errors import join, unknown_name
from .fields import (INVALID, OMIT, Custom, Field, at_least, boolean_or_auto, choice,
                     greater, list_of, mapping, number, text, valid)

METHODS = {"none": 0, "0": 0, "1": 1, "2": 2}
NORMAL_RULES = ("average", "stiffer")


def read_method(raw, path, problems):
    key = str(raw).strip().lower()
    if key not in METHODS:
        problems.add(path, f"must be none, 1 or 2 (seed 001 Secs. 3.1 and 3.2); got {raw!r}")
        return INVALID
    return METHODS[key]


def read_pair_bodies(raw, path, problems):
    if not (isinstance(raw, list) and len(raw) == 2 and all(isinstance(b, str) for b in raw)):
        problems.add(path, f"expected two body names, e.g. [ball, plate]; got {raw!r}")
        return INVALID
    if raw[0] == raw[1]:
        problems.add(path, f"a body cannot be in contact with itself ({raw[0]!r})")
        return INVALID
    return list(raw)


def read_separation(raw, path, problems):
    """Cells > 0, or none (null): no separation check, the paper's detection."""
    if raw is None or str(raw).strip().lower() == "none":
        return None
    return number(greater(0))(raw, path, problems)


def read_release(raw, path, problems):
    """Cells >= 0, none (null): no release rule, the paper's contact, or auto (the
    default, :func:`resolve_contact_defaults`)."""
    if raw is None or str(raw).strip().lower() == "none":
        return None
    if str(raw).strip().lower() == AUTO:
        return AUTO
    return number(at_least(0))(raw, path, problems)


AUTO = "auto"
SEPARATION = Custom(read_separation, "number > 0, or `none`")
RELEASE = Custom(read_release, "number >= 0, `none` or `auto`")
NORMAL = "`average`, `stiffer`"
COUPLINGS = ("surface", "grid")
GAP_MEASURES = ("reach", "volume", AUTO)
COUPLING_DOC = ("how an FEM body and a particle body meet (seed 004): `surface` (ICFEMP, "
                "Sec. 3): the FEM body's free element faces are master segments and the "
                "particles (each a sphere of half its spacing) are kept out of them by a "
                "velocity constraint with the pair's Coulomb friction, whatever the element "
                "size and with any contact.method; `grid` (CFEMP, Sec. 2.4): the FE nodes "
                "join the multi-velocity grid contact as particles of their body (needs "
                "method 1 or 2, and elements about the size of a cell). Two FEM bodies "
                "meet the same way: `surface`, node-to-surface contact, the free-surface "
                "nodes of each kept out of the other's free faces with the pair's "
                "friction (docs/validation/fem_contact.md); `grid`, both bodies' FE nodes "
                "in the grid contact (seed 004's AFEMP; method 1 only; "
                "docs/validation/ogive_plate_fem.md)")
PAIR = {
    "bodies": Field(Custom(read_pair_bodies, "two body names"),
                    doc="the two bodies of the pair, e.g. [ball, plate]"),
    "friction": Field(number(at_least(0)), OMIT, "1",
                      "Coulomb coefficient of this pair (left out: contact.friction)"),
    "normal": Field(Custom(text(), NORMAL + ", or a body of the pair"), OMIT,
                    doc="as contact.normal, or one of the pair's two bodies: that body's own "
                        "normal, e.g. of a flat or convex surface (Sec. 2.3 choice 2; left "
                        "out: contact.normal)"),
    "separation": Field(SEPARATION, OMIT, "cells",
                        "as contact.separation, for this pair (`none`: no check for this "
                        "pair; left out: contact.separation)"),
    "release": Field(RELEASE, OMIT, "cells",
                     "as contact.release, for this pair (`none`: not for this pair; left "
                     "out: contact.release)"),
    "coupling": Field(choice(COUPLINGS, "coupling"), OMIT,
                      doc="as contact.coupling, for a pair of an FEM body and a particle "
                          "body, or `surface` for a pair of FEM bodies: node-to-surface "
                          "contact, where `normal` chooses the masters (a body of the pair: "
                          "its faces only; `stiffer`: the stiffer body's; `average`: both "
                          "ways, one symmetric pass), or `grid` for two FEM bodies on the "
                          "grid (AFEMP, contact.method 1) (left out: contact.coupling)"),
}
CONTACT = {
    "method": Field(Custom(read_method, "`none`, `1`, `2`"), 0,
                    doc="`none` (stored as 0): one shared velocity field, standard MPM, "
                        "where bodies that meet stick together; 1: every body has its own "
                        "velocity field at the nodes two or more bodies reach, and the "
                        "impenetrability condition is imposed on the trial velocities at the "
                        "end of the step (Sec. 3.1); 2: also on the velocities the stresses "
                        "are updated with, at the start of the step (Sec. 3.2, Eqs. 23-25)"),
    "friction": Field(number(at_least(0)), 0.0, "1",
                      "Coulomb coefficient of every pair not listed in pairs"),
    "skip_separating": Field(boolean_or_auto(), AUTO,
                             doc="method 2 only: at the end of a step, leave uncorrected a "
                                 "body that separated from the centre of mass at its start "
                                 "(Eq. 23 false) even if its trial velocity approaches "
                                 "(Eq. 12). The paper corrects it (`false`), which does "
                                 "positive work on particles whose velocities still "
                                 "separate (an elastic sphere gained up to 36 % of its "
                                 "energy); `true` skips it for every pair, which also "
                                 "drops its friction (a block at rest on a ringing slope "
                                 "slipped); `auto` for the frictionless pairs "
                                 "(docs/validation/defaults.md)"),
    "normal": Field(Custom(text(), NORMAL), "average",
                    doc="how the two bodies' normals (Eq. 9) are made collinear (Sec. 2.3): "
                        "`average` is Eq. 10; `stiffer` uses the stiffer body's own normal "
                        "for both (wave modulus K + 4G/3, rigid bodies stiffest; equal: "
                        "average)"),
    "separation": Field(SEPARATION, OMIT, "cells",
                        "the separation check: a node is in contact only if the mass- and "
                        "shape-function-weighted mean positions of the two bodies' particles "
                        "there lie at most this many cell sizes (of the node's grid level) "
                        "apart along the normal; left out or `none`: no check, the paper's "
                        "detection (Sec. 2.2). With grid coupling (CFEMP) it is the "
                        "improved detection of Ma et al. that seed 004 Sec. 2.4.1 uses "
                        "(0.9: docs/validation/sphere_rolling_fem.md)"),
    "release": Field(RELEASE, AUTO, "cells",
                     "the release rule (methods 1 and 2): no contact force at a node where "
                     "the two bodies' surfaces, placed half a particle spacing beyond their "
                     "outermost particles there, are more than this many cells apart along "
                     "the normal, so bodies that part keep their momentum (0: contact only "
                     "across a closed gap; docs/validation/two_bars.md). With it, a node "
                     "inside one body that the other's outermost particles reach takes "
                     "the normal of the body that has a surface there, and Coulomb "
                     "friction is limited by the normal change the body's particles keep "
                     "(under APIC method 2's start correction too), so a sliding impact "
                     "takes mu times its normal impulse "
                     "(docs/validation/angular_momentum.md). `none`: seed 001's contact. "
                     "`auto` (the default): 0 where particle bodies meet through the grid, "
                     "seed 001's contact where an FEM body is coupled through the grid "
                     "(docs/validation/defaults.md; the start line names the choice)"),
    "gap": Field(choice(GAP_MEASURES, "gap measure"), AUTO,
                 doc="how the release rule measures the gap at a node: `reach`: from the "
                     "particles that reach farthest towards the other body, each widened by "
                     "half its spacing (exact for flat faces along the grid axes, so bodies "
                     "part cleanly; but the farthest point anywhere in the node's support, "
                     "so curved surfaces meet early and stiffly); `volume`: from the share "
                     "of the node's trilinear hat each body's particle volumes fill, "
                     "inverted to the depth of a flat face (weighs the surfaces at the node, "
                     "so curved contact converges: docs/validation/hertz.md; under gimp from "
                     "the particles' initial volumes, which err towards closed by about the "
                     "compressive strain and so hold a pressed contact: docs/validation/"
                     "two_bars.md; a flat face that parts slowly may be touched again); "
                     "linear and gimp shape functions "
                     "only; `auto` (the default): `volume`, `reach` with bspline"),
    "coupling": Field(choice(COUPLINGS, "coupling"), "surface", doc=COUPLING_DOC),
    "pairs": Field(list_of(mapping(PAIR), 0, "pair"), [],
                   doc="the pairs of bodies with their own friction, normal or separation"),
}


def check_contact(contact, body_names, problems):
    """Pairs name known bodies, each pair once; normals name a rule or a body of the pair."""
    if contact is INVALID:
        return
    if valid(contact, "normal") and contact["normal"] not in NORMAL_RULES:
        problems.add("contact.normal", f"must be average or stiffer (a body's own normal is "
                     f"chosen per pair); got {contact['normal']!r}")
    pairs = contact.get("pairs")
    if not isinstance(pairs, list):
        return
    seen = {}
    for i, pair in enumerate(pairs):
        path = join("contact.pairs", i)
        if pair is INVALID or not valid(pair, "bodies"):
            continue
        known = True
        for j, name in enumerate(pair["bodies"]):
            if name not in body_names:
                problems.add(join(join(path, "bodies"), j), unknown_name("body", name, body_names))
                known = False
        key = frozenset(pair["bodies"])
        if key in seen:
            problems.add(join(path, "bodies"), f"pair listed twice (also contact.pairs[{seen[key]}])")
        seen.setdefault(key, i)
        normal = pair.get("normal")
        if known and normal is not None and normal is not INVALID \
                and normal not in NORMAL_RULES and normal not in pair["bodies"]:
            problems.add(join(path, "normal"),
                         f"must be average, stiffer or one of the pair's bodies "
                         f"{pair['bodies']}; got {normal!r}")


def resolve_contact_defaults(case):
    """Turn ``contact.release`` and ``contact.gap`` left at ``auto`` into the rule the
    validation matrix supports (docs/validation/defaults.md): the release rule (0 cells)
    with the volume gap, the reach gap with bspline (the volume gap reads the hat's
    shares); seed 001's contact for a case with an FEM body coupled through the grid (the
    release rule is not validated with FE nodes on the grid). Per-pair releases left out
    inherit the section's. Idempotent: a resolved case validates to itself."""
    contact, grid = case.get("contact"), case.get("grid")
    if contact is INVALID or not isinstance(contact, dict):
        return
    if contact.get("release") == AUTO:
        contact["release"] = None if grid_coupled_fem(case) or not contact.get("method") \
            else 0.0
    if contact.get("gap") == AUTO:
        shape = grid.get("shape_functions") if isinstance(grid, dict) else None
        contact["gap"] = "reach" if shape == "bspline" else "volume"
    for pair in contact.get("pairs") or []:
        if isinstance(pair, dict) and pair.get("release") == AUTO:
            pair["release"] = contact["release"]


def grid_coupled_fem(case):
    """Whether an FEM body meets a particle body through the grid (CFEMP)."""
    bodies = case.get("bodies")
    contact = case["contact"]
    if not isinstance(bodies, list) or not any(
            isinstance(b, dict) and b.get("method") == "fem" for b in bodies):
        return False
    pair_couplings = [p.get("coupling") for p in contact.get("pairs") or []
                      if isinstance(p, dict)]
    return contact.get("coupling") == "grid" or "grid" in pair_couplings


def describe_contact(contact):
    """The contact rule in words, for the start line (None without grid contact)."""
    if not contact.method:
        return None
    if contact.release is None:
        rule = f"contact: method {contact.method}, seed 001's detection"
    else:
        rule = (f"contact: method {contact.method}, release rule ({contact.release:g} "
                f"cells, {contact.gap} gap)")
    return rule + SEPARATING.get(contact.skip_separating, "") if contact.method == 2 else rule


#: how the start line names ``skip_separating`` (method 2 only)
SEPARATING = {AUTO: ", parting frictionless pairs left alone",
              True: ", parting pairs left alone", False: ""}


def check_gap_measure(contact, grid, problems):
    """The volume gap is the release rule's, and reads the hat's shares (linear, gimp)."""
    if contact is INVALID or not valid(contact, "gap") or contact["gap"] != "volume":
        return
    releases = contact.get("release") is not None or any(
        isinstance(p, dict) and p.get("release") is not None for p in contact.get("pairs") or [])
    if not releases:
        problems.add("contact.gap", "the volume gap is how the release rule measures the "
                     "gap: set contact.release (e.g. 0) as well")
    if isinstance(grid, dict) and grid.get("shape_functions") == "bspline":
        problems.add("contact.gap", "the volume gap reads the shares of the trilinear hat "
                     "that linear and gimp shape functions weigh with; with bspline use "
                     "gap: reach")
