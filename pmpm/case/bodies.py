"""Validation of ``bodies:`` (geometry, rotation, particles per cell, velocity) and the
checks that need the filled particles (inside the grid box, not empty, mesh readable,
no two bodies overlapping)."""
import math
import os
import re

import numpy as np

from .errors import describe, join
from .fem import FEM, METHOD_DOC, METHODS, fem_mesh_or_none
from .fields import (INVALID, OMIT, REQUIRED, Checked, Custom, Field, FieldNumber,
                     FieldVector, Tagged, at_least, choice, defaults_of, greater,
                     has_invalid, integer, list_of,
                     valid, mapping, number, text, vector)
from .fill import FILE_ERRORS, file_problem, fill_geometry
from .rigid import RIGID
from .shapes import (AXES, make_shape, nose_length, quad_turns, reference_point,
                     rotation_matrix)

_NAME = re.compile(r"^[A-Za-z0-9_-]+$")


def point(doc, default=REQUIRED):
    """A position (mm)."""
    return Field(vector(), default, "mm", doc)


def size(doc):
    """A length > 0 (mm), required."""
    return Field(number(greater(0)), unit="mm", doc=doc)


GEOMETRIES = {
    "box": {"min": point("lower corner"), "max": point("upper corner (min < max)")},
    "cylinder": {
        "base": point("centre of the base"),
        "axis": Field(choice(AXES, "axis"), doc="the axis the cylinder runs along from base"),
        "radius": size("outer radius"),
        "length": size("length along the axis"),
        "inner_radius": Field(number(at_least(0)), 0.0, "mm",
                              "inner radius, < radius (> 0: a tube or a ring)")},
    "sphere": {"center": point("centre"), "radius": size("radius")},
    "ogive": {
        "tip": point("the tip of the nose (give tip or base)", OMIT),
        "base": point("the centre of the flat end (give tip or base)", OMIT),
        "direction": Field(vector(nonzero=True),
                           doc="from base to tip, any length (stored as a unit vector)"),
        "length": size("total length, nose included: at least the nose length "
                       "diameter * sqrt(crh - 1/4)"),
        "diameter": size("shank diameter"),
        "crh": Field(number(at_least(0.5)), unit="1",
                     doc="caliber-radius-head psi: the nose is a tangent ogive of radius "
                         "psi * diameter (0.5: a hemisphere, 3: a 3-CRH projectile)")},
    "mesh": {
        "file": Field(text(), doc="a volume mesh meshio reads (tetra and hexahedron cells "
                                  "are used, others ignored), relative to the case file"),
        "scale": Field(number(greater(0)), 1.0, "1",
                       "the mesh's points x are placed at scale * x + translate"),
        "translate": point("where the mesh's origin lands", [0.0, 0.0, 0.0])},
    "surface": {
        "file": Field(text(), doc="a closed (watertight) triangulated surface meshio reads "
                                  "(.stl, .obj, .ply, .off, ...; quads and polygons are cut "
                                  "into triangles), relative to the case file"),
        "scale": Field(number(greater(0)), 1.0, "1",
                       "the surface's points x are placed at scale * x + translate"),
        "translate": point("where the surface's origin lands", [0.0, 0.0, 0.0])},
    "points": {
        "file": Field(text(), doc="the particles, one per point, relative to the case file: "
                                  "a CSV table (.csv, .txt: a header of column names, then "
                                  "one row per particle; lines starting with # skipped), "
                                  "an HDF5 file (.h5, .hdf5) or a point cloud meshio reads "
                                  "(.vtu, .vtk, .ply, ...: its points)"),
        "coordinates": Field(list_of(text(), 1, "name"), OMIT,
                             doc="where the positions are: CSV, the x, y, z columns' names "
                                 "(left out: [x, y, z]); HDF5, one (n, 3) dataset or three "
                                 "(n,) datasets (required); a meshio file: left out (its "
                                 "points)"),
        "volume": Field(text(), OMIT, doc="the CSV column, HDF5 dataset or point data array "
                                          "of each particle's volume (mm^3, before scale: "
                                          "times scale^3), each > 0; give volume or "
                                          "spacing"),
        "spacing": Field(number(greater(0)), OMIT, "mm",
                         "the particles' spacing (after scale): each has volume "
                         "spacing^3; give volume or spacing"),
        "scale": Field(number(greater(0)), 1.0, "1",
                       "the file's points x are placed at scale * x + translate"),
        "translate": point("where the file's origin lands", [0.0, 0.0, 0.0])},
    "union": {"of": Field(Custom(lambda *a: _read_members(*a), "list of geometries (2 at "
                                 "least)"),
                          doc="the shapes joined: each a geometry mapping (box, cylinder, "
                              "sphere, ogive, prism, union or difference) with its own "
                              "rotate if any")},
    "difference": {"of": Field(Custom(lambda *a: _read_members(*a), "list of geometries "
                                      "(2 at least)"),
                               doc="the first shape, less the others (each a geometry "
                                   "mapping: box, cylinder, sphere, ogive, prism, union or "
                                   "difference, with its own rotate if any)")},
    "prism": {
        "section": Field(list_of(vector(2), 3, "point"), unit="mm",
                         doc="the section's points [a, b]: (x, y) for a prism along z, "
                             "(z, x) along y, (y, z) along x"),
        "blocks": Field(list_of(list_of(integer(at_least(0)), 4, "index"), 1, "block"),
                        doc="the section as convex quadrilaterals, each 4 indices of "
                            "section points counter-clockwise in (a, b), neighbours "
                            "sharing whole edges (an FEM mesh cuts every block into the "
                            "same n x n elements)"),
        "axis": Field(choice(AXES, "axis"), doc="the axis the section is extruded along"),
        "base": Field(number(), unit="mm", doc="where along the axis the prism begins"),
        "length": size("length along the axis")},
}
ROTATE = {
    "axis": Field(vector(nonzero=True), doc="the rotation axis"),
    "angle_deg": Field(number(), unit="deg", doc="right-handed angle about the axis"),
    "origin": point("the point the body turns about (left out: the reference point: box "
                    "min, cylinder base, sphere center, ogive base or else tip, mesh, "
                    "surface and points translate, union and difference their first "
                    "shape's)", OMIT),
}


def _body_name(value, path, problems):
    name = text()(value, path, problems)
    if name is not INVALID and not _NAME.match(name):
        problems.add(path, f"{name!r}: use letters, digits, _ and - only "
                     "(names become column names in history.csv)")
        return INVALID
    return name


def _complete_geometry(geometry, path, problems):
    """The checks of the geometry's type; a rotation's origin defaults to the reference
    point."""
    if geometry is INVALID:
        return geometry
    CHECKS[geometry["type"]](geometry, path, problems)
    if "rotate" in geometry and not has_invalid(geometry):
        geometry["rotate"].setdefault("origin", reference_point(geometry))
    return geometry


GEOMETRY_DOCS = {
    "box": "an axis-aligned box (rotate it for an oblique plate); reference point: min",
    "cylinder": "a solid or hollow circular cylinder along x, y or z; reference point: base",
    "sphere": "a sphere; reference point: center",
    "ogive": "a cylindrical shank with a tangent-ogive nose of radius crh * diameter and "
             "length diameter * sqrt(crh - 1/4); reference point: base, or tip when only "
             "the tip is given",
    "mesh": "the lattice points inside the tetrahedra and hexahedra of a volume mesh "
            "(.msh, .vtu, .vtk, .inp, .med, ...); reference point: translate",
    "surface": "the lattice points inside a closed triangulated surface (an STL or OBJ "
               "file from CAD): inside by ray parity along x, y and z, the majority "
               "deciding; an open surface (an edge on one triangle only) or one whose "
               "facets are not oriented consistently is refused; reference point: "
               "translate",
    "points": "the particles of a point file as they are, one per point (no lattice, no "
              "symmetry clipping: every point must lie inside the grid box), each of volume "
              "`volume` or spacing^3 and mass density * volume; the solver sizes the "
              "particles (uGIMP) by particles_per_cell, so set it to about cell / "
              "spacing; reference point: translate",
    "union": "the lattice points inside any of the shapes `of` (nesting allowed); "
             "reference point: the first shape's",
    "difference": "the lattice points inside the first shape of `of` and inside none of "
                  "the others, e.g. a plate with a hole; reference point: the first "
                  "shape's",
    "prism": "a section made of convex quadrilateral blocks extruded along x, y or z "
             "(a wedge's section, a plate's profile); reference point: the first section "
             "point on the base plane",
}
ROTATION = Field(mapping(ROTATE), OMIT, doc="turn the body, filled in its own frame, about "
                                            "an axis (below)")
GEOMETRY = Checked(Tagged(GEOMETRIES, "geometry type", {"rotate": ROTATION}, GEOMETRY_DOCS),
                   _complete_geometry)
BODY = mapping({
    "name": Field(Custom(_body_name, "string of letters, digits, _, -"),
                  doc="unique; names become history.csv column names"),
    "material": Field(text(), doc="a key of materials"),
    "geometry": Field(GEOMETRY, doc="the shape filled with particles"),
    "particles_per_cell": Field(integer(at_least(1)), 2,
                                doc="particles per cell per direction (2: 8 per cell)"),
    "velocity": Field(FieldVector(), [0.0, 0.0, 0.0], "mm/ms",
                      "initial velocity (global axes, not rotated); each component a number "
                      "or an expression of the position x, y, z, e.g. \"2 * sin(pi * x / "
                      "100)\" (parameters as ${name})"),
    "temperature": Field(FieldNumber(), OMIT, "K",
                         "initial temperature, a number or an expression of x, y, z "
                         "(default: the material's T_room, the Johnson-Cook reference)"),
    "method": Field(choice(METHODS, "body method"), "particles", doc=METHOD_DOC),
    "fem": Field(mapping(FEM), defaults_of(FEM),
                 doc="the elements of a `method: fem` body (refused on a particle body)"),
    "rigid": Field(mapping(RIGID), defaults_of(RIGID),
                   doc="the motion of a body of a `rigid` material (ignored for others; "
                       "a free axis of another body is refused)"),
})


def check_min_below_max(box, path, problems):
    """Report (and mark INVALID) a box whose min is not below its max on every axis."""
    if not valid(box, "min", "max"):
        return False
    bad = [f"{'xyz'[a]}: {box['min'][a]:g} >= {box['max'][a]:g}" for a in range(3)
           if box["min"][a] >= box["max"][a]]
    if bad:
        problems.add(path, "min must be < max in every direction (" + "; ".join(bad) + ")")
        box["max"] = INVALID
    return not bad


def _check_cylinder(g, path, problems):
    if valid(g, "inner_radius", "radius") and g["inner_radius"] >= g["radius"]:
        problems.add(join(path, "inner_radius"), f"must be < radius = {g['radius']:g}")
        g["inner_radius"] = INVALID


def _check_ogive(g, path, problems):
    if ("tip" in g) == ("base" in g):
        problems.add(path, "give exactly one of 'tip' and 'base'")
        g["tip"] = INVALID
    if valid(g, "diameter", "crh", "length"):
        nose = nose_length(g["diameter"], g["crh"])
        if nose > g["length"] * (1 + 1e-12):
            problems.add(join(path, "length"), f"must be >= the nose length diameter * "
                         f"sqrt(crh - 1/4) = {nose:g}")
            g["length"] = INVALID
    if not valid(g, "direction"):
        return
    norm = math.sqrt(sum(c * c for c in g["direction"]))
    g["direction"] = [c / norm for c in g["direction"]]


def _check_prism(g, path, problems):
    """Every block names existing section points and is convex and counter-clockwise."""
    if not valid(g, "section", "blocks"):
        return
    points = np.asarray(g["section"], float)
    for k, block in enumerate(g["blocks"]):
        where = join(join(path, "blocks"), k)
        if len(block) != 4:
            problems.add(where, f"a block is 4 section points, not {len(block)}")
            g["blocks"] = INVALID
        elif max(block) >= len(points):
            problems.add(where, f"index {max(block)} names no point: the section has "
                         f"{len(points)}")
            g["blocks"] = INVALID
        elif not (quad_turns(points[block]) > 0).all():
            problems.add(where, "not a convex quadrilateral counter-clockwise in the "
                         "section's (a, b): reorder or split it")
            g["blocks"] = INVALID


def _check_points_geometry(g, path, problems):
    """Exactly one of volume and spacing."""
    if ("volume" in g) == ("spacing" in g):
        problems.add(path, "give exactly one of 'volume' (a column of the file) and "
                     "'spacing' (each particle's volume spacing^3)")
        g["file"] = INVALID


#: the shapes a union or difference is made of (the analytic ones)
CSG_MEMBERS = ("box", "cylinder", "sphere", "ogive", "prism", "union", "difference")


def _read_members(value, path, problems):
    """The list of a union's or difference's shapes, each a geometry mapping of an
    analytic type (a file has no analytic inside test to combine)."""
    if not isinstance(value, list) or len(value) < 2:
        problems.add(path, f"expected a list of at least 2 geometries, got "
                     f"{describe(value)}")
        return INVALID
    members = []
    for i, item in enumerate(value):
        member = GEOMETRY(item, join(path, i), problems)
        if member is not INVALID and member.get("type") not in CSG_MEMBERS:
            problems.add(join(join(path, i), "type"),
                         f"a {member['type']} cannot be part of a union or difference "
                         f"(only {', '.join(CSG_MEMBERS)})")
            member = INVALID
        members.append(member)
    return members


CHECKS = {"box": check_min_below_max, "cylinder": _check_cylinder, "sphere": lambda *a: None,
          "ogive": _check_ogive, "mesh": lambda *a: None, "prism": _check_prism,
          "surface": lambda *a: None, "points": _check_points_geometry,
          "union": lambda *a: None, "difference": lambda *a: None}


def check_bodies_in_grid(bodies, grid, case_dir, problems):
    """Fill every valid body; report unreadable meshes, empty bodies, bodies that
    extend outside the grid box, and bodies that overlap."""
    filled = {}
    for i, body in enumerate(bodies):
        if body is INVALID or has_invalid(body["geometry"], body["particles_per_cell"]):
            continue
        path = join(join("bodies", i), "geometry")
        if body.get("method") == "fem":
            mesh = fem_mesh_or_none(body, grid, case_dir)
            if mesh is not None:
                check_nodes_in_grid(mesh[0], grid, path, problems)
                filled[i] = (mesh[0][mesh[1]].mean(axis=1),
                             body["fem"].get("element_size", grid["cell"]))
            continue
        try:
            points, volumes = fill_geometry(body["geometry"], grid,
                                            body["particles_per_cell"], case_dir)
        except FILE_ERRORS as error:
            key, message = file_problem(body["geometry"], error)
            problems.add(join(path, key), message)
            continue
        if body["geometry"]["type"] == "points":
            _check_file_points(points, body["geometry"], grid, path, problems)
            filled[i] = (points, float(np.cbrt(volumes.mean())))
            continue
        _check_points(points, grid, body["particles_per_cell"], path, problems)
        filled[i] = (points, grid["cell"] / body["particles_per_cell"])
    check_overlaps(bodies, filled, problems)


def _in_shape_frame(points, geometry):
    """Points in the unrotated frame the geometry's shape is given in."""
    rotate = geometry.get("rotate")
    if not rotate:
        return points
    origin = np.asarray(rotate["origin"], float)
    return origin + (points - origin) @ rotation_matrix(rotate["axis"], rotate["angle_deg"])


#: the geometries read from a file, which the overlap check does not test points against
FILE_GEOMETRIES = ("mesh", "surface", "points")


def _inside(points, geometry):
    """Which ``points`` lie inside the analytic ``geometry`` (None for a file's)."""
    if geometry["type"] in FILE_GEOMETRIES or len(points) == 0:
        return None
    return make_shape(geometry).contains(_in_shape_frame(points, geometry))


def check_overlaps(bodies, filled, problems):
    """One problem per pair of bodies where particles of one lie inside the other's shape:
    their mass would count twice there. ``filled`` maps a body's index to its particles'
    positions and spacing. The shape of a body from a file (mesh, surface, points) is not
    tested (only the analytic shapes of the others against its particles)."""
    for j in sorted(filled):
        for i in sorted(filled):
            if i >= j:
                break
            for inner, outer in ((j, i), (i, j)):
                points, spacing = filled[inner]
                inside = _inside(points, bodies[outer]["geometry"])
                count = 0 if inside is None else int(np.count_nonzero(inside))
                if count:
                    problems.add(
                        join(join("bodies", j), "geometry"),
                        f"body '{bodies[j]['name']}' overlaps body '{bodies[i]['name']}' "
                        f"(bodies[{i}]): {count} particles of '{bodies[inner]['name']}' "
                        f"(volume {count * spacing ** 3:.3g}) lie inside "
                        f"'{bodies[outer]['name']}'; bodies may not overlap")
                    break


def check_mesh_files(bodies, case_dir, problems):
    """Cheap check used when bodies are not filled: every mesh, surface or point file
    exists."""
    for i, body in enumerate(bodies):
        geometry = body["geometry"] if body is not INVALID else INVALID
        if geometry is INVALID or has_invalid(geometry) or \
                geometry["type"] not in FILE_GEOMETRIES:
            continue
        if not os.path.isfile(os.path.join(case_dir, geometry["file"])):
            problems.add(join(join(join("bodies", i), "geometry"), "file"),
                         f"cannot read {geometry['file']!r}: no such file")


def check_nodes_in_grid(points, grid, path, problems):
    """An FEM body's nodes lie inside the grid box at the start (on its faces at most:
    FE nodes are not dropped like particles, and one outside faults at step 1)."""
    tol = 1e-9 * grid["cell"]
    lo, hi = points.min(axis=0), points.max(axis=0)
    outside = [f"{'xyz'[a]} from {lo[a]:g} to {hi[a]:g}, grid {grid['min'][a]:g} to "
               f"{grid['max'][a]:g}" for a in range(3)
               if lo[a] < grid["min"][a] - tol or hi[a] > grid["max"][a] + tol]
    if outside:
        count = int(np.count_nonzero(((points < np.asarray(grid["min"]) - tol) |
                                      (points > np.asarray(grid["max"]) + tol)).any(axis=1)))
        problems.add(path, f"{count} nodes of the FEM body lie outside the grid box ("
                     + "; ".join(outside) + "); nodes may lie on its faces, not beyond")


def _check_file_points(points, geometry, grid, path, problems):
    """Every particle of a point file lies inside the grid box (min <= x < max, as
    particles are kept)."""
    outside = ((points < np.asarray(grid["min"])) |
               (points >= np.asarray(grid["max"]))).any(axis=1)
    if outside.any():
        first = np.flatnonzero(outside)[0]
        problems.add(join(path, "file"), f"{int(outside.sum())} of the {len(points)} "
                     f"points of {geometry['file']!r} lie outside the grid box (point "
                     f"{first} at ({', '.join(f'{v:g}' for v in points[first])}), grid "
                     f"{grid['min']} to {grid['max']}); move them (translate) or widen "
                     f"the grid")


def _check_points(points, grid, particles_per_cell, path, problems):
    if len(points) == 0:
        spacing = grid["cell"] / particles_per_cell
        problems.add(path, f"no particle falls inside the shape (particle spacing "
                     f"{spacing:g}); is it smaller than the spacing?")
        return
    lo, hi = points.min(axis=0), points.max(axis=0)
    outside = [f"{'xyz'[a]} from {lo[a]:g} to {hi[a]:g}, grid {grid['min'][a]:g} to "
               f"{grid['max'][a]:g}" for a in range(3)
               if lo[a] < grid["min"][a] or hi[a] >= grid["max"][a]]
    if outside:
        problems.add(path, "body extends outside the grid box (" + "; ".join(outside) + ")")
