"""The keys of an FEM body (``method: fem``, ``fem:``) and the checks that relate them to
the rest of the case: the geometries an FEM mesh is made from, a readable and
well-oriented mesh, and the coupling of FEM bodies to particle bodies (``contact.coupling``,
seed 004's CFEMP and ICFEMP)."""
import os

import numpy as np

from .errors import join, unknown_name
from .fields import (INVALID, OMIT, Field, at_least, at_most, boolean, choice, defaults_of,
                     greater, has_invalid, integer, list_of, mapping, number, text, valid, vector)
from .hexmesh import (InvertedElementError, MeshDefectError, MixedMeshError, box_counts,
                      hex_mesh, ogive_counts, prism_divisions, read_node_sets)
from .mesh import MeshReadError

METHODS = ("particles", "fem")
HOURGLASS_DEFAULTS = {"stiffness": 0.05, "viscous": 0.1}
#: element formulations (pmpm.fem.elements, pmpm.fem.assumed_strain)
ELEMENTS = ("reduced", "assumed_strain")
#: the largest hourglass coefficient a case may give (pmpm.fem.stability)
MAX_HOURGLASS = 0.5
FEM_GEOMETRIES = ("box", "cylinder", "sphere", "ogive", "prism", "mesh")
AXIS_NAMES = ("x", "y", "z")
CONSTRAINT = {
    "region": Field(mapping({"min": Field(vector(), unit="mm", doc="lower corner"),
                             "max": Field(vector(), unit="mm", doc="upper corner")}),
                    OMIT, "mm", "the body's nodes inside this box at t = 0 (give region or "
                                "node_set)"),
    "node_set": Field(text(), OMIT, doc="a node set of the body's mesh file (Abaqus *NSET, "
                                        "meshio point_sets, or a Gmsh .msh physical group "
                                        "of any dimension by its name: the nodes of its "
                                        "cells; give region or node_set)"),
    "fix": Field(list_of(choice(AXIS_NAMES, "axis"), 1, "axis"),
                 doc="the velocity components held at zero, e.g. [x, y, z] (clamped) or [z]"),
}
#: the most particles per direction an element converts into (issue 24)
MAX_CONVERT_DIVISIONS = 6
CONVERT = {
    "eps_p": Field(number(at_least(0)), OMIT, "1",
                   "an element converts when its plastic strain reaches this (seed 004 "
                   "Sec. 4.2: 0.9; left out: not on plastic strain)"),
    "volume_ratio": Field(number(greater(0), at_most(1)), OMIT, "1",
                          "an element converts when its volume falls to this fraction of "
                          "its initial volume (left out: only when it would invert)"),
    "step_ratio": Field(number(greater(0), at_most(1)), OMIT, "1",
                        "an element converts when its stable time step (as the force pass "
                        "takes it) falls to this fraction of the background cell's step: "
                        "the step at rest of an undistorted cube one grid.cell wide of the "
                        "body's material and element (about cell / (1.8 c) with the "
                        "viscous hourglass form), the step the grid costs the run anyway. "
                        "Erosion on the time step: a squeezed, sheared or hourglassed "
                        "element does not set a collapsing step for the whole run, and its "
                        "particles run at the grid's step. The reference does not depend "
                        "on the mesh, so neither does the shortest step an element may "
                        "keep; an element finer than this fraction of the cell converts "
                        "after the first step (a warning counts them). Left out: not on "
                        "the step; the oblique perforation uses 0.2"),
    "failed": Field(boolean(), True,
                    doc="an element converts when its material has failed (damage 1: "
                        "eps_p reached the material's eps_fail, or its damage model's D "
                        "reached 1); as particles the failed material carries no deviator, "
                        "as the particles of a particle body do, where as an element it "
                        "resists no shear and distorts until another criterion converts "
                        "it or it inverts (false: a failed element stays an element)"),
    "particles_per_direction": Field(integer(at_least(1), at_most(MAX_CONVERT_DIVISIONS)), 2,
                                     "1", "an element becomes n^3 particles at the centres "
                                          "of its n^3 sub-cells (seed 004: 2, 8 particles)"),
}
FEM = {
    "convert": Field(mapping(CONVERT), OMIT,
                     doc="element-to-particle conversion (IAFEMP, seed 004 Secs. 3-4): an "
                         "element that reaches a criterion below, and always one that would "
                         "invert, becomes particles of the same body that carry its material "
                         "state and the velocity of its nodes, conserving mass and momentum; "
                         "they meet what remains of the mesh, and every other FEM body, "
                         "through surface contact; where the body meets bodies on the grid "
                         "(contact.coupling grid: AFEMP, CFEMP), they form a particle body "
                         "of their own, NAME_converted in the outputs, that meets its mesh "
                         "and the other bodies on the grid (left out: elements never "
                         "convert, and an inverted element stops the run)"),
    "element_size": Field(number(greater(0)), OMIT, "mm",
                          "edge of the elements a box is cut into: round(edge / "
                          "element_size) elements, at least 1, along each edge of the box; "
                          "a sphere is a cubed sphere of round(diameter / element_size) "
                          "elements (even, at least 2) along each axis, a solid cylinder an "
                          "O-grid disc of as many across, swept in round(length / "
                          "element_size) layers, a tube polar blocks, an ogive the same "
                          "disc swept along its shank and, in layers thinning with the "
                          "radius, its nose down to where the disc's elements are one "
                          "element_size wide, then closed to the pointed tip by half a "
                          "cubed ball (nose elements 0.5-3.5 sizes long), each section "
                          "scaled out to its circle's area so the rod keeps its mass "
                          "(left out: grid.cell); a mesh file keeps its own elements"),
    "element": Field(choice(ELEMENTS, "element"), "reduced",
                     doc="the hexahedron: `reduced`, one-point integration with the "
                         "hourglass control below (its bending with one or two elements "
                         "through a thickness is much too stiff or too soft); "
                         "`assumed_strain`, one-point integration with the hourglass "
                         "modes resisted by the strain energy of an assumed strain field "
                         "in the element's corotational frame (Belytschko-Bindeman style, "
                         "pmpm.fem.assumed_strain): exact in pure bending of a rectangular "
                         "element, a cantilever's first peak within 2 % of beam theory with "
                         "one or two elements through its thickness "
                         "(docs/validation/fem_bending.md), at 1.2 times the reduced "
                         "element's cost; its hourglass stiffness takes the material's "
                         "elastic moduli, the shear modulus scaled by the elastic share of "
                         "the strain increment in a step where the element yields; it "
                         "takes no `hourglass` or `hourglass_coefficient`"),
    "hourglass": Field(choice(tuple(HOURGLASS_DEFAULTS), "hourglass form"), OMIT,
                       doc="Flanagan-Belytschko hourglass control of the one-point "
                           "elements (element `reduced`; left out: `stiffness`): "
                           "`stiffness` resists the hourglass displacement (elastic "
                           "plates, slow loading), `viscous` its rate (impact)"),
    "hourglass_coefficient": Field(number(at_least(0), at_most(MAX_HOURGLASS)), OMIT, "1",
                                   "the hourglass coefficient k (left out: 0.05 for "
                                   "stiffness, 0.1 for viscous): viscous Q = k rho c "
                                   "V^(2/3)/4 q, stiffness dQ/dt = k rho c^2 (sum of b.b)/(3V) q, "
                                   "with q the hourglass velocity rates. The element's stable "
                                   "step includes it (at cfl 1 no element grows); at most "
                                   "0.5: beyond about 0.25 (stiffness) the hourglass modes, "
                                   "not the physical ones, set the step, 1.8 times shorter "
                                   "at 0.5 on a cube"),
    "constraints": Field(list_of(mapping(CONSTRAINT), 0, "constraint"), [],
                         doc="velocity components held at zero on nodes chosen by a box "
                             "or a node set (besides the grid faces' conditions, which "
                             "nodes on a face take)"),
}
METHOD_DOC = ("`particles`: the body is filled with material points; `fem`: it is a mesh "
              "of 8-node hexahedra (a box, cylinder, sphere, ogive, prism or mesh file) advanced by explicit central "
              "differences with lumped masses, one-point integration and hourglass "
              "control (seed 004 Sec. 2.3); over MPI an element belongs to the rank whose slab "
              "holds its centroid; with a `rigid` material it moves with its velocity (in the axes "
              "`rigid.free` names, under the contact impulses and gravity). FEM "
              "bodies feel gravity, loads and the grid's face conditions (a node on a fixed, slip "
              "or symmetry face takes that condition) and meet particle bodies as "
              "contact.coupling says: `surface` (ICFEMP, seed 004 Sec. 3): the particles are "
              "kept out of the body's free element faces, with the pair's Coulomb friction (and "
              "FEM bodies meet each other the same way, node to surface); "
              "`grid` (CFEMP, Sec. 2.4; contact.method 1 or 2): their nodes join the "
              "multi-velocity grid contact as particles of their body, on the coarse grid "
              "(no refined window over them; usf only), and take the contact's velocity "
              "change; it wants elements about a cell in size (larger ones let particles "
              "leak in between the nodes) and, with FE nodes on grid nodes, `gimp` or "
              "`bspline` shape functions (the hat's gradient jumps at a node, which spoils "
              "the normal)")


def check_fem_bodies(case, case_dir, check_geometry, problems):
    """Complete each FEM body's ``fem`` mapping (element size, hourglass coefficient) and
    report what an FEM body cannot be used with yet."""
    bodies = case["bodies"] if case["bodies"] is not INVALID else []
    fem_names = set()
    for i, body in enumerate(bodies):
        if not valid(body, "method", "fem") or body["method"] != "fem":
            continue
        path = join("bodies", i)
        if valid(body, "name"):
            fem_names.add(body["name"])
        check_element(body["fem"], path, problems)
        complete_fem(body["fem"], case["grid"])
        check_constraints(body, path, problems)
        if valid(body, "geometry"):
            check_fem_geometry(body, case_dir, check_geometry, path, problems)
    if fem_names:
        check_coupling(case, fem_names, problems)
        check_mixed_coupling(case, fem_names, problems)
        check_converted_names(case, problems)


def check_element(fem, path, problems):
    """An assumed_strain element takes its hourglass stiffness from its material: an
    hourglass form or coefficient given with it would be ignored, so it is refused."""
    if not (valid(fem, "element") and fem["element"] == "assumed_strain"):
        return
    for key in ("hourglass", "hourglass_coefficient"):
        if key in fem:
            problems.add(join(join(path, "fem"), key),
                         f"the assumed_strain element takes its hourglass stiffness from "
                         f"its material; {key} is for element 'reduced'")


def check_fem_keys_on_particle_bodies(raw_bodies, bodies, problems):
    """A ``fem:`` block on a body whose method is ``particles`` would be ignored (its
    element size, its node-set clamps): refuse it, naming the key, rather than run the
    body unclamped without a word. A block equal to the defaults (what validation fills
    in, so a validated case validates again) is let through."""
    if not isinstance(raw_bodies, list) or bodies is INVALID:
        return
    defaults = defaults_of(FEM)
    for i, (raw, body) in enumerate(zip(raw_bodies, bodies)):
        if not isinstance(raw, dict) or "fem" not in raw or body is INVALID:
            continue
        if valid(body, "method") and body["method"] == "particles" and \
                body.get("fem") != defaults:
            problems.add(join(join("bodies", i), "fem"),
                         "a fem: block on a particle body would be ignored (its constraints "
                         "too); set method: fem to mesh the body with elements, or remove "
                         "the block (clamp particles with grid.boundary or a window)")


def complete_fem(fem, grid):
    if valid(fem, "element") and fem["element"] == "reduced":
        fem.setdefault("hourglass", "stiffness")
    if valid(fem, "hourglass"):
        fem.setdefault("hourglass_coefficient", HOURGLASS_DEFAULTS[fem["hourglass"]])
    if "element_size" not in fem and valid(grid, "cell"):
        fem["element_size"] = grid["cell"]


#: The most elements a box body may be cut into (each takes about 1 kB with its nodes).
MAX_ELEMENTS = 1e8


def check_fem_geometry(body, case_dir, check_geometry, path, problems):
    geometry = body["geometry"]
    if has_invalid(geometry):
        return
    if geometry["type"] not in FEM_GEOMETRIES:
        problems.add(join(join(path, "geometry"), "type"),
                     f"an FEM body is made from a box, cylinder, sphere, ogive, prism or mesh, "
                     f"not a {geometry['type']} (mesh it and give the file)")
        return
    if not valid(body["fem"], "element_size") or too_many_elements(body, path, problems):
        return
    if not check_geometry:
        return
    key = join(join(path, "geometry"), "file" if geometry["type"] == "mesh" else "type")
    try:
        hex_mesh(geometry, body["fem"]["element_size"], case_dir)
        check_node_sets(body, case_dir, path, problems)
    except MeshReadError as error:
        line = f"{key}: cannot read {geometry['file']!r}: {error}"
        if line not in problems.lines:       # the particle fill's check may have said it
            problems.add(key, line[len(key) + 2:])
    except (InvertedElementError, MixedMeshError, MeshDefectError) as error:
        problems.add(key, str(error))


def check_constraints(body, path, problems):
    """Each constraint names exactly one of region and node_set; node sets need a mesh."""
    constraints = body["fem"].get("constraints") if valid(body, "fem") else None
    if not isinstance(constraints, list):
        return
    for j, item in enumerate(constraints):
        if not isinstance(item, dict):
            continue
        where = join(join(join(path, "fem"), "constraints"), j)
        if ("region" in item) == ("node_set" in item):
            problems.add(where, "give exactly one of 'region' and 'node_set'")
        elif "node_set" in item and valid(body, "geometry") and \
                body["geometry"]["type"] != "mesh":
            problems.add(join(where, "node_set"), "node sets come with a mesh file; this "
                         "body is a " + body["geometry"]["type"])
        elif valid(item, "region"):
            low, high = item["region"]["min"], item["region"]["max"]
            if any(a > b for a, b in zip(low, high)):
                problems.add(join(where, "region"), "min must not exceed max")


def check_node_sets(body, case_dir, path, problems):
    """Every node_set a constraint names is in the body's mesh file."""
    names = [(j, c["node_set"]) for j, c in enumerate(body["fem"].get("constraints", []))
             if isinstance(c, dict) and isinstance(c.get("node_set"), str)]
    if not names or body["geometry"]["type"] != "mesh":
        return
    sets = read_node_sets(os.path.join(case_dir, body["geometry"]["file"]))
    for j, name in names:
        if name not in sets:
            problems.add(join(join(join(join(path, "fem"), "constraints"), j), "node_set"),
                         unknown_name("node set", name, sets))


def element_count(geometry, size):
    """How many elements ``size`` cuts a box, sphere, cylinder or ogive into, counted as
    case.hexmesh cuts them but in floating point (inf past 1e308, no OverflowError);
    None for a mesh file."""
    kind = geometry["type"]
    with np.errstate(over="ignore", invalid="ignore"):
        if kind == "box":
            return float(np.prod(box_counts(geometry["min"], geometry["max"], size)
                                 .astype(np.float64)))
        if kind == "sphere":
            return float(_across(geometry["radius"], size) ** 3)
        if kind == "prism":
            n = prism_divisions(geometry["section"], geometry["blocks"], size)
            layers = max(np.rint(np.float64(geometry["length"]) / size), 1.0)
            return float(len(geometry["blocks"]) * n * n * layers)
        if kind == "cylinder":
            layers = max(np.rint(np.float64(geometry["length"]) / size), 1.0)
            inner = geometry.get("inner_radius", 0.0)
            if inner > 0:
                radial = max(np.rint(np.float64(geometry["radius"] - inner) / size), 1.0)
                around = max(np.rint(np.pi * np.float64(geometry["radius"] + inner) / size),
                             8.0)
                return float(radial * around * layers)
            return float(_across(geometry["radius"], size) ** 2 * layers)
        if kind == "ogive":
            across, shank, nose = ogive_counts(geometry, size)
            return float(across ** 2 * (shank + nose))
    return None


def _across(radius, size):
    """hexmesh.across in floating point: round(diameter / size), even, at least 2."""
    n = max(np.rint(np.float64(2.0 * radius) / size), 2.0)
    return n + np.fmod(n, 2.0)


def too_many_elements(body, path, problems):
    geometry, size = body["geometry"], body["fem"]["element_size"]
    kind = geometry["type"]
    count = element_count(geometry, size)
    if count is None:
        return False
    if count > MAX_ELEMENTS:
        problems.add(join(join(path, "fem"), "element_size"),
                     f"{size:g} cuts the {kind} into {count:.3g} elements, more than "
                     f"{MAX_ELEMENTS:.0e}")
        return True
    return False


def check_coupling(case, fem_names, problems):
    """FEM bodies meet particle bodies by ``contact.coupling`` (or a pair's): grid coupling
    needs the multi-velocity grid (method 1 or 2); in a surface pair the FEM body is the
    master, so a pair's ``normal`` may not name its particle body; two FEM bodies meet on
    the grid with method 1 only (:data:`FEM_PAIR_ON_GRID`); a window follows particle
    bodies only."""
    contact = case["contact"]
    if contact is INVALID:
        return
    method = contact.get("method")
    if valid(contact, "coupling") and contact["coupling"] == "grid" and method == 0:
        problems.add("contact.coupling", "grid coupling (CFEMP) puts the FE nodes into "
                     "the multi-velocity grid contact: set contact.method to 1 or 2, or "
                     "use surface coupling")
    elif valid(contact, "coupling") and contact["coupling"] == "grid" \
            and len(fem_names) > 1 and not all_fem_pairs_listed(contact, fem_names):
        if method == 2:
            problems.add("contact.method", FEM_PAIR_ON_GRID)
        if is_number(contact.get("release")):
            problems.add("contact.release", FEM_PAIR_RELEASE)
    for i, pair in enumerate(contact.get("pairs") or []):
        if isinstance(pair, dict) and valid(pair, "bodies"):
            check_pair_coupling(pair, join("contact.pairs", i), contact, fem_names, problems)
    grid = case["grid"]
    windows = grid.get("windows") if isinstance(grid, dict) else None
    for i, window in enumerate(windows if isinstance(windows, list) else []):
        if valid(window, "follow") and window["follow"] in fem_names:
            problems.add(f"grid.windows[{i}].follow", f"'{window['follow']}' is an FEM "
                         f"body: a window follows particle bodies only")


#: what the name of the particle body that holds an FEM body's converted elements adds
#: (pmpm.case.config.converted_bodies)
CONVERTED = "_converted"


def fem_bodies_on_grid(case):
    """The names of the FEM bodies that meet some other body on the grid: by
    ``contact.coupling`` unless a pair of ``contact.pairs`` says otherwise (a validated
    contact section and body names)."""
    contact, bodies = case["contact"], case["bodies"]
    fem = {b["name"] for b in bodies if b["method"] == "fem"}
    names = [b["name"] for b in bodies]
    ways = {frozenset((a, b)): contact["coupling"] for i, a in enumerate(names)
            for b in names[i + 1:] if a in fem or b in fem}
    for pair in contact["pairs"]:
        key = frozenset(pair["bodies"])
        if key in ways:
            ways[key] = pair.get("coupling") or contact["coupling"]
    return {name for key, way in ways.items() if way == "grid" for name in key
            if name in fem}


def check_converted_names(case, problems):
    """A converting FEM body on the grid adds the particle body NAME_converted for its
    elements' particles: no body of the case may already have that name."""
    contact, bodies = case["contact"], case["bodies"]
    if bodies is INVALID or not valid(contact, "coupling", "pairs", "method") or \
            not contact["method"] or not all(valid(b, "name", "method") for b in bodies):
        return
    if not all(isinstance(p, dict) and valid(p, "bodies") for p in contact["pairs"]):
        return
    names = [b["name"] for b in bodies]
    on_grid = fem_bodies_on_grid(case)
    for i, body in enumerate(bodies):
        fem = body.get("fem")
        if body["name"] in on_grid and isinstance(fem, dict) and fem.get("convert") \
                and body["name"] + CONVERTED in names:
            problems.add(f"bodies[{names.index(body['name'] + CONVERTED)}].name",
                         f"'{body['name'] + CONVERTED}' is the body that FEM body "
                         f"'{body['name']}' (bodies[{i}]) converts into on the grid; "
                         f"choose another name")


def check_mixed_coupling(case, fem_names, problems):
    """An FEM body meets every particle body by contact.coupling unless a pair says
    otherwise; it cannot meet some on the grid and others by surface contact (as the
    set-up would find, after meshing and filling every body)."""
    contact = case["contact"]
    bodies = case["bodies"] if case["bodies"] is not INVALID else []
    if not valid(contact, "coupling", "pairs") or not all(valid(b, "name") for b in bodies):
        return
    particle_names = [b["name"] for b in bodies if b["name"] not in fem_names]
    for name in sorted(fem_names):
        ways, key = {}, "contact.coupling"
        for other in particle_names:
            ways[other] = contact["coupling"]
        for i, pair in enumerate(contact["pairs"]):
            if isinstance(pair, dict) and valid(pair, "bodies") and name in pair["bodies"]:
                other = [n for n in pair["bodies"] if n != name]
                if other and other[0] in ways:
                    ways[other[0]] = pair.get("coupling", contact["coupling"])
                    key = join(join("contact.pairs", i), "coupling")
        if len(set(ways.values())) > 1:
            grid = sorted(n for n, way in ways.items() if way == "grid")
            surface = sorted(n for n, way in ways.items() if way == "surface")
            problems.add(key, f"FEM body '{name}' would meet {', '.join(grid)} on the grid "
                         f"and {', '.join(surface)} by surface contact; give all its pairs "
                         f"one coupling")


#: why two FEM bodies meet on the grid with method 1 only: method 2's start correction
#: (Eq. 25) takes the approach out of the velocities the stresses use, which the FE nodes
#: never take (their elements' stresses use their own velocities), so the end-of-step
#: correction finds nothing approaching and the bodies pass through each other
FEM_PAIR_ON_GRID = ("two FEM bodies on the grid (AFEMP) need contact.method 1: under "
                    "method 2 the start correction removes the approach the FE nodes never "
                    "take, and the bodies pass through each other; or meet them by surface "
                    "(node-to-surface) contact")


def all_fem_pairs_listed(contact, fem_names):
    """Whether every pair of FEM bodies is listed in contact.pairs (its own coupling)."""
    listed = {frozenset(p["bodies"]) for p in contact.get("pairs") or []
              if isinstance(p, dict) and valid(p, "bodies")}
    names = sorted(fem_names)
    return all(frozenset((a, b)) in listed for i, a in enumerate(names)
               for b in names[i + 1:])


#: why two FEM bodies on the grid take no release rule: its gap is measured from the
#: particles' reach or their shares of a node's hat, which FE nodes (points with a
#: lumped volume) do not give: two FEM bars end-on with `release: 0` passed through
#: each other untouched
FEM_PAIR_RELEASE = ("two FEM bodies on the grid (AFEMP) meet by seed 001's contact: the "
                    "release rule's gap is not measured for FE nodes (two bars end-on "
                    "passed through each other); leave it out, or set none or auto")


def is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def check_pair_coupling(pair, path, contact, fem_names, problems):
    named = [n for n in pair["bodies"] if n in fem_names]
    if len(named) == 2:
        if pair.get("coupling", contact.get("coupling")) == "grid":
            if contact.get("method") != 1:
                problems.add(join(path, "coupling"), FEM_PAIR_ON_GRID)
            if is_number(pair.get("release", contact.get("release"))):
                problems.add(join(path, "release"), FEM_PAIR_RELEASE)
        return
    if not named:
        return
    coupling = pair.get("coupling", contact.get("coupling"))
    if coupling == "grid" and pair.get("coupling") == "grid" and contact.get("method") == 0:
        problems.add(join(path, "coupling"), "grid coupling (CFEMP) needs contact.method "
                     "1 or 2")
    normal = pair.get("normal")
    if coupling == "surface" and isinstance(normal, str) and normal in pair["bodies"] \
            and normal not in fem_names:
        problems.add(join(path, "normal"), f"in surface coupling the FEM body "
                     f"'{named[0]}' is the master: its faces give the normal, not the "
                     f"particle body '{normal}'")


def fem_mesh_or_none(body, grid, case_dir):
    """(points, hexes) of a valid FEM body for the checks against the grid box and the
    other bodies, or None where it cannot be made (check_fem_geometry says why)."""
    geometry, fem = body["geometry"], body.get("fem")
    if has_invalid(geometry) or not isinstance(fem, dict) or has_invalid(fem) or \
            geometry["type"] not in FEM_GEOMETRIES:
        return None
    size = fem.get("element_size", grid["cell"])
    count = element_count(geometry, size)
    if count is not None and not count <= MAX_ELEMENTS:
        return None
    try:
        return hex_mesh(geometry, size, case_dir)
    except (MeshReadError, InvertedElementError, MixedMeshError, MeshDefectError,
            ValueError):
        return None


#: elements wider than this many cells let particles leak between the nodes under grid
#: coupling (issue 27: a symmetric bounce came back at -0.46 m/s with a sideways velocity)
WIDE_ELEMENT = 1.5


def grid_coupling_warnings(case, case_dir="."):
    """Warning lines for the FEM bodies met on the grid (CFEMP) whose widest element
    edge is more than WIDE_ELEMENT cells, naming the ratio (validated ``case``)."""
    contact, cell = case["contact"], case["grid"]["cell"]
    if contact["method"] == 0:
        return []
    lines = []
    for i, body in enumerate(case["bodies"]):
        if body["method"] != "fem" or "grid" not in couplings_of(case, body["name"]):
            continue
        points, hexes = hex_mesh(body["geometry"], body["fem"]["element_size"], case_dir)
        widest = widest_edge(points, hexes)
        if widest > WIDE_ELEMENT * cell:
            lines.append(
                f"bodies[{i}].fem.element_size: FEM body '{body['name']}' meets particles "
                f"on the grid (CFEMP) with elements up to {widest / cell:.3g} cells wide "
                f"({widest:g} against grid.cell {cell:g}): particles leak between the "
                f"nodes of elements wider than about {WIDE_ELEMENT:g} cells; make them "
                f"about a cell wide or use contact.coupling: surface")
    return lines


#: the Courant number above which particle-to-surface contact gains energy with the step
SURFACE_CFL = 0.5


def surface_contact_step_warnings(case):
    """A warning line when particles meet an FEM body by surface contact (ICFEMP) at a
    Courant number above SURFACE_CFL: the contact's energy error grows in proportion to
    the step (docs/validation/surface_contact_impact.md, "The time step"; validated
    ``case``)."""
    time = case["time"]
    if time["dt"] is not None or time["cfl"] <= SURFACE_CFL:
        return []
    for body in case["bodies"]:
        if body["method"] == "fem" and "surface" in couplings_of(case, body["name"]):
            return [f"time.cfl: {time['cfl']:g} with particle-to-surface contact (FEM body "
                    f"'{body['name']}'): the contact's energy error grows with the step "
                    f"(a steel sphere dropped on an FEM block gains 2.7 % of its energy "
                    f"at cfl 0.5 and 13.7 % at 0.8; docs/validation/"
                    f"surface_contact_impact.md); {SURFACE_CFL:g} or less keeps it within "
                    f"a few per cent"]
    return []


def couplings_of(case, name):
    """The couplings by which FEM body ``name`` meets the particle bodies."""
    contact = case["contact"]
    others = {b["name"]: contact["coupling"] for b in case["bodies"]
              if b["method"] != "fem"}
    for pair in contact["pairs"]:
        if name in pair["bodies"]:
            other = [n for n in pair["bodies"] if n != name]
            if other and other[0] in others:
                others[other[0]] = pair.get("coupling", contact["coupling"])
    return set(others.values())


def widest_edge(points, hexes):
    """The longest of the elements' twelve edges."""
    edges = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4],
                      [0, 4], [1, 5], [2, 6], [3, 7]])
    xe = points[hexes]
    return float(np.linalg.norm(xe[:, edges[:, 1]] - xe[:, edges[:, 0]], axis=2).max())
