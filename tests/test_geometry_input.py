"""Geometry input (issue 26): particles from point files (CSV, HDF5, VTU), closed STL/OBJ
surfaces filled on the body's lattice, unions and differences of the built-in shapes,
and Gmsh physical groups as the node sets of FEM constraints. Every file is written by
the test itself."""
import math

import h5py
import meshio
import numpy as np
import pytest
import yaml

from pmpm.case import CaseError, fill_body, load_case
from pmpm.case.hexmesh import box_mesh
from pmpm.case.size import body_estimate

STEEL = {"model": "elastic", "density": 7.8e-3, "E": 2e5, "nu": 0.3}


def case_tree(geometry, cell=1.0, ppc=2, grid=(-10, 10)):
    return {
        "grid": {"min": [grid[0]] * 3, "max": [grid[1]] * 3, "cell": cell},
        "materials": {"steel": STEEL},
        "bodies": [{"name": "part", "material": "steel", "geometry": geometry,
                    "particles_per_cell": ppc}],
        "time": {"end": 0.01},
    }


def write_case(tmp_path, tree, name="case.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(tree, sort_keys=False))
    return path


def filled(tmp_path, geometry, **grid):
    """(positions, volumes) of the one-body case of ``geometry``, validated and filled
    as a run fills it."""
    case = load_case(write_case(tmp_path, case_tree(geometry, **grid)))
    return fill_body(case["bodies"][0], case["grid"], str(tmp_path))


def problems(tmp_path, geometry, **grid):
    with pytest.raises(CaseError) as error:
        load_case(write_case(tmp_path, case_tree(geometry, **grid)))
    return error.value.problems


# --- closed surfaces ----------------------------------------------------------------

def cube_surface(n, half=1.0):
    """The surface of the cube [-half, half]^3 as n x n quads per face, outward:
    (points, quads)."""
    points, quads = [], []
    g = np.linspace(-half, half, n + 1)
    for axis in range(3):
        a, b = (axis + 1) % 3, (axis + 2) % 3
        for side in (-half, half):
            grid = np.zeros((n + 1, n + 1, 3))
            grid[..., axis] = side
            grid[..., a], grid[..., b] = np.meshgrid(g, g, indexing="ij")
            index = sum(len(p) for p in points) + np.arange((n + 1) ** 2).reshape(n + 1, -1)
            quad = np.stack([index[:-1, :-1], index[1:, :-1], index[1:, 1:],
                             index[:-1, 1:]], -1).reshape(-1, 4)
            quads.append(quad if side > 0 else quad[:, ::-1])
            points.append(grid.reshape(-1, 3))
    return np.concatenate(points), np.concatenate(quads)


def triangles(quads):
    return np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def write_stl(path, points, tris):
    meshio.write(str(path), meshio.Mesh(points, [("triangle", tris)]), binary=True)


def sphere_surface(radius, n=32):
    """A cube's surface pushed out onto the sphere: (points, triangles), closed and
    outward; its volume is within 0.15 % of the sphere's at n = 32."""
    points, quads = cube_surface(n)
    return radius * points / np.linalg.norm(points, axis=1)[:, None], triangles(quads)


@pytest.mark.parametrize("cell", [1.0, 0.5])
def test_a_filled_stl_box_has_the_box_volume_and_mass_exactly(tmp_path, cell):
    """A 4 x 6 x 2 box given as an STL of the unit cube's surface scaled and moved:
    whole multiples of the spacing, so the lattice gives its volume and mass exactly
    (columns through the facets' edges and corners too: the tie rule counts each
    crossing once)."""
    points, quads = cube_surface(8)
    points = points * [2, 3, 1] + [2, 3, 1]           # [0, 4] x [0, 6] x [0, 2]
    write_stl(tmp_path / "box.stl", points, triangles(quads))
    geometry = {"type": "surface", "file": "box.stl", "scale": 0.5, "translate": [-1, 2, 3]}
    x, vol = filled(tmp_path, geometry, cell=cell)
    assert vol.sum() == pytest.approx(2 * 3 * 1, rel=1e-12)
    assert len(x) == 6 / (cell / 2) ** 3
    assert x.min(axis=0) == pytest.approx(np.array([-1, 2, 3]) + cell / 4)
    assert x.max(axis=0) == pytest.approx(np.array([1, 5, 4]) - cell / 4)
    assert STEEL["density"] * vol.sum() == pytest.approx(7.8e-3 * 6, rel=1e-12)


@pytest.mark.parametrize("cell, tolerance", [(1.0, 0.01), (0.5, 0.005)])
def test_a_filled_stl_sphere_has_the_sphere_volume(tmp_path, cell, tolerance):
    """A sphere of radius 5 as 12288 facets (its polyhedron 0.12 % smaller than the
    sphere), centred off the lattice: the filled volume and mass are the sphere's
    4/3 pi r^3 (times the density) within 1 % at 2 particles per cell of 1 (measured
    -0.21 %) and 0.5 % at cells of 0.5 (measured -0.14 %); the same surface as an OBJ of
    quads fills the same particles."""
    points, tris = sphere_surface(5.0)
    write_stl(tmp_path / "ball.stl", points, tris)
    quad_points, quads = cube_surface(32)
    meshio.write(str(tmp_path / "ball.obj"), meshio.Mesh(
        5.0 * quad_points / np.linalg.norm(quad_points, axis=1)[:, None], [("quad", quads)]))
    exact = 4 / 3 * math.pi * 5.0 ** 3
    geometry = {"type": "surface", "file": "ball.stl", "translate": [0.3, -0.2, 0.1]}
    x, vol = filled(tmp_path, geometry, cell=cell)
    assert abs(vol.sum() / exact - 1) < tolerance
    assert np.linalg.norm(x - [0.3, -0.2, 0.1], axis=1).max() < 5.0
    assert STEEL["density"] * vol.sum() == pytest.approx(STEEL["density"] * exact,
                                                         rel=tolerance)
    x_obj, _ = filled(tmp_path, {**geometry, "file": "ball.obj"}, cell=cell)
    assert len(x_obj) == len(x) and np.abs(x_obj - x).max() < 1e-12


def test_a_rotated_stl_box_fills_like_the_rotated_box(tmp_path):
    """rotate turns a surface about its translate (the reference point), as the box
    turns about its min: the two fill the same particles."""
    points, quads = cube_surface(4)
    write_stl(tmp_path / "cube.stl", (points + 1) * [2, 1, 1.5], triangles(quads))
    turn = {"axis": [1, 2, 3], "angle_deg": 33}
    surface = {"type": "surface", "file": "cube.stl", "translate": [1, 0, -1],
               "rotate": turn}
    box = {"type": "box", "min": [1, 0, -1], "max": [5, 2, 2], "rotate": turn}
    x_surface, _ = filled(tmp_path, surface)
    x_box, _ = filled(tmp_path, box)
    assert len(x_surface) == len(x_box) == 4 * 2 * 3 * 8
    assert np.abs(x_surface - x_box).max() < 1e-12


def test_an_stl_cube_with_a_face_missing_is_refused_naming_the_file(tmp_path):
    points, quads = cube_surface(2)
    write_stl(tmp_path / "open.stl", points, triangles(quads[4:]))    # one face gone
    [line] = problems(tmp_path, {"type": "surface", "file": "open.stl"})
    assert line.startswith("bodies[0].geometry.file: 'open.stl': not a closed surface: "
                           "8 edges belong to one triangle only"), line


def test_an_stl_with_a_facet_turned_inside_out_is_refused(tmp_path):
    points, quads = cube_surface(2)
    tris = triangles(quads)
    tris[5] = tris[5][::-1]
    write_stl(tmp_path / "flipped.stl", points, tris)
    [line] = problems(tmp_path, {"type": "surface", "file": "flipped.stl"})
    assert line.startswith("bodies[0].geometry.file: 'flipped.stl': the triangles are "
                           "not oriented consistently (3 edges"), line


def test_a_missing_surface_file_is_refused(tmp_path):
    [line] = problems(tmp_path, {"type": "surface", "file": "none.stl"})
    assert line == "bodies[0].geometry.file: cannot read 'none.stl': no such file"


# --- point files --------------------------------------------------------------------

def cloud(n=50, seed=3):
    """Scattered points in [-4, 4]^3 and positive volumes."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-4, 4, (n, 3)), rng.uniform(0.01, 0.2, n)


def write_csv(path, x, vol, header="x,y,z,vol"):
    rows = [header] + [",".join(repr(float(v)) for v in (*p, w)) for p, w in zip(x, vol)]
    path.write_text("\n".join(rows) + "\n")


def test_points_from_csv_are_the_files_particles_and_volumes(tmp_path):
    x, vol = cloud()
    write_csv(tmp_path / "cloud.csv", x, vol)
    got_x, got_vol = filled(tmp_path, {"type": "points", "file": "cloud.csv",
                                       "volume": "vol"})
    assert (got_x == x).all() and (got_vol == vol).all()
    got_x, got_vol = filled(tmp_path, {"type": "points", "file": "cloud.csv",
                                       "spacing": 0.25, "scale": 2.0,
                                       "translate": [1, 0, 0]})
    assert (got_x == 2 * x + [1, 0, 0]).all() and (got_vol == 0.25 ** 3).all()
    got_x, _ = filled(tmp_path, {"type": "points", "file": "cloud.csv", "spacing": 0.25,
                                 "translate": [1, 0, 0],
                                 "rotate": {"axis": [0, 0, 1], "angle_deg": 90}})
    turned = np.stack([1 - x[:, 1], x[:, 0], x[:, 2]], axis=1)   # about (1, 0, 0)
    assert np.abs(got_x - turned).max() < 1e-12


def test_points_from_csv_with_named_columns_and_scaled_volumes(tmp_path):
    x, vol = cloud()
    write_csv(tmp_path / "cloud.csv", x, vol, header="px,py,pz,V")
    got_x, got_vol = filled(tmp_path, {"type": "points", "file": "cloud.csv",
                                       "coordinates": ["px", "py", "pz"], "volume": "V",
                                       "scale": 0.5})
    assert (got_x == 0.5 * x).all() and (got_vol == vol * 0.125).all()


@pytest.mark.parametrize("layout", ["one", "three"])
def test_points_from_hdf5_are_the_files_particles_and_volumes(tmp_path, layout):
    x, vol = cloud()
    with h5py.File(tmp_path / "cloud.h5", "w") as f:
        if layout == "one":
            f["particles/position"] = x
        else:
            for k, name in enumerate("xyz"):
                f[name] = x[:, k]
        f["particles/volume"] = vol
    names = ["particles/position"] if layout == "one" else ["x", "y", "z"]
    got_x, got_vol = filled(tmp_path, {"type": "points", "file": "cloud.h5",
                                       "coordinates": names,
                                       "volume": "particles/volume"})
    assert (got_x == x).all() and (got_vol == vol).all()


def test_points_from_a_vtu_cloud_are_its_points_and_point_data(tmp_path):
    x, vol = cloud()
    meshio.write(str(tmp_path / "cloud.vtu"),
                 meshio.Mesh(x, [("vertex", np.arange(len(x))[:, None])],
                             point_data={"volume": vol}))
    got_x, got_vol = filled(tmp_path, {"type": "points", "file": "cloud.vtu",
                                       "volume": "volume"})
    assert (got_x == x).all() and (got_vol == vol).all()


def test_a_points_body_gets_its_mass_from_the_density(tmp_path):
    """The run's particles: mass = density * the file's volume, positions unchanged."""
    from runhelp import set_up
    x, vol = cloud(20)
    write_csv(tmp_path / "cloud.csv", x, vol)
    path = write_case(tmp_path, case_tree({"type": "points", "file": "cloud.csv",
                                           "volume": "vol"}))
    p = set_up(str(path)).particles
    order = np.argsort(p.id)
    assert (p.x[order] == x).all()
    assert p.mass[order] == pytest.approx(STEEL["density"] * vol, rel=1e-15)


def bad_cloud(tmp_path):
    x, vol = cloud(10)
    write_csv(tmp_path / "cloud.csv", x, vol)
    vol[7] = 0.0
    write_csv(tmp_path / "zero.csv", x, vol)
    x[3] = [12, 0, 0]
    write_csv(tmp_path / "far.csv", x, np.ones(10))
    with h5py.File(tmp_path / "cloud.h5", "w") as f:
        f["position"] = x
    (tmp_path / "text.csv").write_text("# exported\nx,y,z,vol\n1,2,3,0.1\n1,2,oops,0.1\n")


@pytest.mark.parametrize("geometry, key, words", [
    ({"file": "none.csv", "volume": "vol"}, "file", "cannot read 'none.csv': no such file"),
    ({"file": "cloud.csv", "volume": "V"}, "volume",
     "'cloud.csv' has no column 'V' (its header: x, y, z, vol)"),
    ({"file": "cloud.csv", "coordinates": ["x", "y", "w"], "volume": "vol"}, "coordinates",
     "'cloud.csv' has no column 'w'"),
    ({"file": "zero.csv", "volume": "vol"}, "volume",
     "point 7 of 'zero.csv' (of 1 such) has volume 0: every volume must be finite and > 0"),
    ({"file": "far.csv", "volume": "vol"}, "file",
     "1 of the 10 points of 'far.csv' lie outside the grid box (point 3 at (12, 0, 0)"),
    ({"file": "cloud.csv"}, "",
     "give exactly one of 'volume' (a column of the file) and 'spacing'"),
    ({"file": "cloud.csv", "volume": "vol", "spacing": 0.1}, "",
     "give exactly one of 'volume'"),
    ({"file": "cloud.h5", "spacing": 0.1}, "coordinates", "name the HDF5 dataset"),
    ({"file": "cloud.h5", "coordinates": ["pos"], "spacing": 0.1}, "coordinates",
     "'cloud.h5' has no dataset 'pos' (its datasets: position)"),
    ({"file": "cloud.csv", "spacing": -1}, "spacing", "must be > 0"),
    ({"file": "text.csv", "volume": "vol"}, "file",
     "'text.csv': expected numbers in columns x, y, z, vol below the header (line 2)"),
])
def test_bad_point_files_are_refused_naming_the_key(tmp_path, geometry, key, words):
    bad_cloud(tmp_path)
    [line] = problems(tmp_path, {"type": "points", **geometry})
    where = "bodies[0].geometry" + (f".{key}" if key else "")
    assert line.startswith(where + ": ") and words in line, line


# --- unions and differences -----------------------------------------------------------

PLATE = {"type": "box", "min": [-5, -5, -2], "max": [5, 5, 2]}
HOLE = {"type": "cylinder", "base": [0, 0, -3], "axis": "z", "radius": 3, "length": 6}


def lattice_volume(tmp_path, geometry, cell=0.5):
    x, vol = filled(tmp_path, geometry, cell=cell)
    return x, vol.sum()


@pytest.mark.parametrize("cell, tolerance", [(0.5, 0.01), (0.25, 0.004)])
def test_a_box_less_a_cylinder_has_the_closed_form_volume(tmp_path, cell, tolerance):
    """A 10 x 10 x 4 plate less a hole of radius 3: 400 - 36 pi, within 1 % (measured
    +0.38 %) and 0.4 % (measured +0.12 %) at particle spacings 0.25 and 0.125."""
    x, volume = lattice_volume(tmp_path, {"type": "difference", "of": [PLATE, HOLE]}, cell)
    assert abs(volume / (400 - 36 * math.pi) - 1) < tolerance
    assert np.hypot(x[:, 0], x[:, 1]).min() > 3
    assert x.min(axis=0) == pytest.approx([-5 + cell / 4, -5 + cell / 4, -2 + cell / 4])


def test_a_union_of_two_spheres_has_the_closed_form_volume(tmp_path):
    """Two spheres of radius 3 whose centres are 2 apart: 2 (4/3 pi r^3) less the lens
    they share, pi (4r + d)(2r - d)^2 / 12, within 1 % (measured -0.03 %); the union's
    bounds reach both."""
    a = {"type": "sphere", "center": [-1, 0, 0], "radius": 3}
    b = {"type": "sphere", "center": [1, 0, 0], "radius": 3}
    x, volume = lattice_volume(tmp_path, {"type": "union", "of": [a, b]}, 0.25)
    exact = 2 * 4 / 3 * math.pi * 27 - math.pi * (12 + 2) * (6 - 2) ** 2 / 12
    assert abs(volume / exact - 1) < 0.01
    assert x[:, 0].min() < -3.8 and x[:, 0].max() > 3.8


def test_nested_and_turned_shapes_combine(tmp_path):
    """(plate less hole) joined to a bar turned 90 degrees about z standing on the
    plate: the plate's closed form plus the bar's 1 x 8 x 2, within 1 %; the bar, turned
    by its own rotate, lies on x in [-5, -4], y in [-4, 4]."""
    bar = {"type": "box", "min": [0, 0, 2], "max": [8, 1, 4],
           "rotate": {"axis": [0, 0, 1], "angle_deg": 90, "origin": [0, -4, 2]}}
    geometry = {"type": "union", "of": [{"type": "difference", "of": [PLATE, HOLE]}, bar]}
    x, volume = lattice_volume(tmp_path, geometry, 0.25)
    assert abs(volume / (400 - 36 * math.pi + 16) - 1) < 0.01
    top = x[x[:, 2] > 2]
    assert top.min(axis=0) == pytest.approx([-5 + 0.0625, -4 + 0.0625, 2 + 0.0625])
    assert top.max(axis=0) == pytest.approx([-4 - 0.0625, 4 - 0.0625, 4 - 0.0625])


def test_a_difference_is_estimated_by_its_volume(tmp_path):
    """The memory estimate of a union or difference counts its sample (no closed form):
    within 2 % of the particles the fill makes (measured -0.2 %)."""
    tree = case_tree({"type": "difference", "of": [PLATE, HOLE]}, cell=0.5)
    case = load_case(write_case(tmp_path, tree))
    estimate, _ = body_estimate(case["bodies"][0], case["grid"], str(tmp_path))
    x, _ = fill_body(case["bodies"][0], case["grid"], str(tmp_path))
    assert abs(estimate / len(x) - 1) < 0.02


@pytest.mark.parametrize("geometry, key, words", [
    ({"type": "union", "of": [PLATE]}, "bodies[0].geometry.of",
     "expected a list of at least 2 geometries"),
    ({"type": "difference", "of": [PLATE, {"type": "mesh", "file": "a.vtu"}]},
     "bodies[0].geometry.of[1].type", "a mesh cannot be part of a union or difference"),
    ({"type": "union", "of": [PLATE, {**HOLE, "radius": -1}]},
     "bodies[0].geometry.of[1].radius", "must be > 0"),
])
def test_bad_unions_are_refused_naming_the_key(tmp_path, geometry, key, words):
    [line] = problems(tmp_path, geometry)
    assert line.startswith(key + ": ") and words in line, line


# --- Gmsh physical groups ----------------------------------------------------------------

def block_with_base():
    """A 2 x 2 x 2 block of unit hexahedra and the quads of its z = 0 face."""
    points, hexes = box_mesh([0, 0, 0], [2, 2, 2], [2, 2, 2])
    quads = np.array([h[:4] for h in hexes if (points[h[:4], 2] == 0).all()])
    return points, hexes, quads


def write_msh22(path, points, hexes, quads):
    """Gmsh 2.2 (meshio's writer): groups SOLID (3D, tag 1) and BASE (2D, tag 2)."""
    meshio.write(str(path), meshio.Mesh(
        points, [("hexahedron", hexes), ("quad", quads)],
        cell_data={"gmsh:physical": [np.full(len(hexes), 1), np.full(len(quads), 2)],
                   "gmsh:geometrical": [np.full(len(hexes), 1), np.full(len(quads), 1)]},
        field_data={"SOLID": np.array([1, 3]), "BASE": np.array([2, 2])}),
        file_format="gmsh22", binary=False)


def write_msh41(path, points, hexes, quads):
    """Gmsh 4.1 as Gmsh writes it (entities, physical names), by hand."""
    lines = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat", "$PhysicalNames", "2",
             '2 2 "BASE"', '3 1 "SOLID"', "$EndPhysicalNames", "$Entities", "0 0 1 1",
             "1 0 0 0 2 2 0 1 2 0", "1 0 0 0 2 2 2 1 1 1 1", "$EndEntities", "$Nodes",
             f"1 {len(points)} 1 {len(points)}", f"3 1 0 {len(points)}"]
    lines += [str(k + 1) for k in range(len(points))]
    lines += [" ".join(f"{c:.17g}" for c in p) for p in points]
    n = len(quads) + len(hexes)
    lines += ["$EndNodes", "$Elements", f"2 {n} 1 {n}", f"2 1 3 {len(quads)}"]
    lines += [" ".join(map(str, [k + 1, *(q + 1)])) for k, q in enumerate(quads)]
    lines += [f"3 1 5 {len(hexes)}"]
    lines += [" ".join(map(str, [len(quads) + k + 1, *(h + 1)]))
              for k, h in enumerate(hexes)]
    path.write_text("\n".join(lines + ["$EndElements"]) + "\n")


@pytest.mark.parametrize("writer", [write_msh22, write_msh41])
def test_a_gmsh_physical_group_clamps_exactly_its_nodes(tmp_path, writer):
    """The block falls under gravity with its Gmsh group BASE (the quads of its z = 0
    face) clamped: after a few steps exactly the 9 base nodes are where they started,
    every other node has moved."""
    from runhelp import set_up
    points, hexes, quads = block_with_base()
    writer(tmp_path / "block.msh", points, hexes, quads)
    tree = case_tree({"type": "mesh", "file": "block.msh", "translate": [0, 0, -9]})
    tree["bodies"][0].update(method="fem", fem={"element_size": 1.0, "constraints": [
        {"node_set": "BASE", "fix": ["x", "y", "z"]}]}, velocity=[0, 0, -5.0])
    tree["gravity"] = [0, 0, -1e3]
    sim = set_up(str(write_case(tmp_path, tree)))
    fem = sim.elements
    start = fem.x.copy()
    for _ in range(5):
        sim.advance(0.5 * sim.grid.h / sim.fastest_speed())
    still = (fem.x == start).all(axis=1)
    base = np.isclose(start[:, 2], -9.0)
    assert base.sum() == 9 and (still == base).all()


def test_an_unknown_gmsh_group_is_refused_with_the_known_ones(tmp_path):
    points, hexes, quads = block_with_base()
    write_msh41(tmp_path / "block.msh", points, hexes, quads)
    tree = case_tree({"type": "mesh", "file": "block.msh"})
    tree["bodies"][0].update(method="fem", fem={"constraints": [
        {"node_set": "TOP", "fix": ["z"]}]})
    with pytest.raises(CaseError) as error:
        load_case(write_case(tmp_path, tree))
    [line] = error.value.problems
    assert line == ("bodies[0].fem.constraints[0].node_set: unknown node set 'TOP'; "
                    "known: BASE, SOLID"), line


def test_gmsh_groups_of_points_and_lines_are_node_sets_too(tmp_path):
    """Groups of any dimension: a physical point (the corner node) and a physical curve
    (the two edges along x at y = z = 0: three nodes); a tag reused by groups of other
    dimensions picks only the cells of its own."""
    from pmpm.case.hexmesh import read_node_sets
    points, hexes, quads = block_with_base()
    corner = np.flatnonzero((points == 0).all(axis=1))
    edge = np.flatnonzero((points[:, 1] == 0) & (points[:, 2] == 0))
    edge = edge[np.argsort(points[edge, 0])]
    lines = np.stack([edge[:-1], edge[1:]], axis=1)
    meshio.write(str(tmp_path / "block.msh"), meshio.Mesh(
        points, [("hexahedron", hexes), ("quad", quads), ("line", lines),
                 ("vertex", corner[:, None])],
        cell_data={"gmsh:physical": [np.full(len(hexes), 1), np.full(len(quads), 2),
                                     np.full(len(lines), 1), np.full(1, 1)],
                   "gmsh:geometrical": [np.full(len(hexes), 1), np.full(len(quads), 1),
                                        np.full(len(lines), 1), np.full(1, 1)]},
        field_data={"SOLID": np.array([1, 3]), "BASE": np.array([2, 2]),
                    "EDGE": np.array([1, 1]), "CORNER": np.array([1, 0])}),
        file_format="gmsh22", binary=False)
    sets = read_node_sets(tmp_path / "block.msh")
    assert sorted(sets) == ["BASE", "CORNER", "EDGE", "SOLID"]
    assert sets["CORNER"].tolist() == corner.tolist()
    assert sorted(sets["EDGE"].tolist()) == sorted(edge.tolist()) and len(edge) == 3
    assert len(sets["BASE"]) == 9 and len(sets["SOLID"]) == 27


def test_an_stl_box_under_a_refined_window_keeps_its_volume(tmp_path):
    """Inside a window of ratio 2 the surface is filled at half the spacing (8 times the
    particles per volume), outside it at the coarse spacing: the volume stays exact."""
    points, quads = cube_surface(4)
    write_stl(tmp_path / "box.stl", (points + 1) * [2, 3, 1], triangles(quads))
    tree = case_tree({"type": "surface", "file": "box.stl"})
    tree["grid"]["windows"] = [{"min": [-2, -2, -2], "max": [2, 8, 4], "ratio": 2}]
    case = load_case(write_case(tmp_path, tree))
    x, vol = fill_body(case["bodies"][0], case["grid"], str(tmp_path))
    assert vol.sum() == pytest.approx(4 * 6 * 2, rel=1e-12)
    fine = x[:, 0] < 2
    assert fine.sum() == 2 * 6 * 2 * 64 and (~fine).sum() == 2 * 6 * 2 * 8
