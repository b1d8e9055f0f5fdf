"""Issue 27: FEM bodies and the meshes they read are checked at the door: exit 2 with
one line naming the key (and the element or node), never a traceback, a wrong first
error, or a body silently wrong (a repeated hexahedron's mass counted twice); and the
checks that treated an FEM body as a volume filled with particles (the grid box, the
memory estimate) take its nodes and elements."""
import os

import meshio
import numpy as np
import pytest
import yaml

from clihelp import CASES, pmpm, pmpm_lines
from pmpm.case import CaseError, load_case

CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                 [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
KEY = "bodies[0].geometry.file"


def two_hexes(merged=True):
    """Two unit hexahedra side by side along x, sharing their four middle nodes (or,
    unmerged, each with its own)."""
    if not merged:
        return np.concatenate([CUBE, CUBE + [1, 0, 0]]), np.arange(16).reshape(2, 8)
    points = np.concatenate([CUBE, CUBE[[1, 2, 5, 6]] + [1, 0, 0]])
    return points, np.array([[0, 1, 2, 3, 4, 5, 6, 7], [1, 8, 9, 2, 5, 10, 11, 6]])


def case(tmp_path, geometry, grid=None, **extra):
    tree = {"grid": grid or {"min": [-2, -2, -2], "max": [4, 3, 3], "cell": 1.0},
            "materials": {"steel": {"model": "elastic", "density": 7.8e-3, "E": 2e5,
                                    "nu": 0.3}},
            "bodies": [{"name": "part", "material": "steel", "method": "fem",
                        "geometry": geometry, **extra}],
            "time": {"end": 0.001}}
    path = tmp_path / "case.yaml"
    path.write_text(yaml.safe_dump(tree))
    return path


def mesh_case(tmp_path, points, cells, name="part.vtu"):
    meshio.write(tmp_path / name, meshio.Mesh(points, cells))
    return case(tmp_path, {"type": "mesh", "file": name})


def problems(path):
    with pytest.raises(CaseError) as error:
        load_case(str(path))
    return error.value.problems


def mutated(change):
    points, hexes = two_hexes()
    points, hexes = points.copy(), hexes.copy()
    change(points, hexes)
    return points, [("hexahedron", hexes)]


DEFECTS = {
    "nan node": (lambda p, h: p.__setitem__((3, 1), np.nan),
                 "node 3 (of 1 such) has coordinates that are not finite (0, nan, 0)"),
    "infinite node": (lambda p, h: p.__setitem__((9, 2), np.inf),
                      "node 9 (of 1 such) has coordinates that are not finite (2, 1, inf)"),
    "index past the nodes": (lambda p, h: h.__setitem__((1, 3), 40),
                             "hexahedron 1 (of 1 such) names node 40, but the mesh's "
                             "nodes are 0 to 11"),
    "negative index": (lambda p, h: h.__setitem__((1, 3), -1),
                       "hexahedron 1 (of 1 such) names node -1, but the mesh's nodes are "
                       "0 to 11"),
}


@pytest.mark.parametrize("name", sorted(DEFECTS))
def test_a_mesh_with_a_bad_node_is_refused_naming_it(tmp_path, name):
    change, words = DEFECTS[name]
    points, cells = mutated(change)
    assert problems(mesh_case(tmp_path, points, cells)) == [f"{KEY}: {words}"]


def test_unmerged_nodes_are_refused_with_their_count(tmp_path):
    points, hexes = two_hexes(merged=False)
    assert problems(mesh_case(tmp_path, points, [("hexahedron", hexes)])) == [
        f"{KEY}: 4 nodes lie at the same place as another node (nodes 1 and 8 at (1, 0, "
        f"0)): the elements there share no node and are not connected; merge the mesh's "
        f"coincident nodes"]


def test_a_hexahedron_listed_twice_is_refused(tmp_path):
    points, hexes = two_hexes()
    cells = [("hexahedron", hexes), ("hexahedron", hexes[:1])]
    assert problems(mesh_case(tmp_path, points, cells)) == [
        f"{KEY}: 1 hexahedra repeat another's nodes (hexahedron 2 is hexahedron 0 again): "
        f"their mass would count twice; remove the repeats"]


@pytest.mark.parametrize("suffix", ["msh", "inp"])
def test_an_empty_cell_block_is_left_out_and_a_mesh_of_none_refused(tmp_path, suffix):
    """An Abaqus file's empty block reads as shape (0,) (before: IndexError)."""
    points, hexes = two_hexes()
    empty = ("hexahedron", np.zeros((0, 8), int))
    load_case(str(mesh_case(tmp_path, points, [empty, ("hexahedron", hexes)],
                            f"two.{suffix}")))
    assert problems(mesh_case(tmp_path, points, [empty], f"none.{suffix}")) == [
        f"{KEY}: cannot read 'none.{suffix}': no hexahedron cells, which an FEM body needs "
        f"(found: hexahedron (0))"]


@pytest.mark.parametrize("geometry", [
    {"type": "sphere", "center": [0, 0, 0], "radius": 1.0},
    {"type": "cylinder", "base": [0, 0, 0], "axis": "z", "radius": 1.0, "length": 1.0}])
def test_a_tiny_element_size_on_a_sphere_or_cylinder_is_refused(tmp_path, geometry):
    path = case(tmp_path, geometry, fem={"element_size": 1e-300})
    assert problems(path) == [
        f"bodies[0].fem.element_size: 1e-300 cuts the {geometry['type']} into inf "
        f"elements, more than 1e+08"]


def test_fem_nodes_outside_the_grid_box_are_refused_in_validation(tmp_path):
    """The particle lattice of this plate (its points half a spacing inside) lies in the
    grid; its nodes at x = 2.2 do not (before: exit 1 at step 1)."""
    path = case(tmp_path, {"type": "box", "min": [0, 0, 0], "max": [2.2, 1, 1]},
                grid={"min": [-1, -1, -1], "max": [2, 2, 2], "cell": 1.0},
                fem={"element_size": 1.1})
    assert problems(path) == [
        "bodies[0].geometry: 4 nodes of the FEM body lie outside the grid box (x from 0 "
        "to 2.2, grid -1 to 2); nodes may lie on its faces, not beyond"]


def test_a_plate_thinner_than_half_a_cell_is_taken(tmp_path):
    """Before: 'no particle falls inside the shape'."""
    path = case(tmp_path, {"type": "box", "min": [0, 0, 0], "max": [2, 2, 0.2]})
    assert load_case(str(path))["bodies"][0]["method"] == "fem"


def test_an_fem_plate_is_estimated_by_its_elements(tmp_path):
    """400 elements on a fine grid: as particles of the grid's spacing it would be
    3.2e6 particles and 2 GB, refused under 1 GB; its elements and the grid's nodes
    take 0.5 GB."""
    path = case(tmp_path, {"type": "box", "min": [0, 0, 0], "max": [20, 20, 1]},
                grid={"min": [-1, -1, -1], "max": [21, 21, 2], "cell": 0.1},
                fem={"element_size": 1.0})
    tree = yaml.safe_load(path.read_text())
    tree["decomposition"] = {"memory_limit_gb": 1}
    path.write_text(yaml.safe_dump(tree))
    assert load_case(str(path))["bodies"][0]["fem"]["element_size"] == 1.0


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_bad_mesh_exits_2_with_one_line_on_every_rank_count(tmp_path, ranks):
    change, words = DEFECTS["negative index"]
    points, cells = mutated(change)
    path = mesh_case(tmp_path, points, cells)
    done = pmpm([path, "--out", tmp_path / "out"], ranks)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert pmpm_lines(done.stderr) == [f"pmpm: error: {KEY}: {words}"]


def test_grid_coupling_with_elements_wider_than_a_cell_is_warned_about_naming_the_ratio(
        tmp_path):
    """CFEMP with elements of 3 cells (4 through the plate; such a bounce came back at
    -0.46 m/s, sideways); the 1-cell elements of the shipped case say nothing."""
    bounce = os.path.join(CASES, "fem_grid_bounce.yaml")
    quick = ["--quiet", "--set", "time.end=0.0001"]
    done = pmpm([bounce, "--out", tmp_path / "wide", *quick, "--set",
                 "params.element=0.006"], timeout=300)
    assert done.returncode == 0, done.stderr
    assert pmpm_lines(done.stderr) == [
        "pmpm: warning: bodies[0].fem.element_size: FEM body 'plate' meets particles on "
        "the grid (CFEMP) with elements up to 4 cells wide (0.008 against grid.cell "
        "0.002): particles leak between the nodes of elements wider than about 1.5 cells; "
        "make them about a cell wide or use contact.coupling: surface"]
    done = pmpm([bounce, "--out", tmp_path / "fine", *quick], timeout=300)
    assert done.returncode == 0 and pmpm_lines(done.stderr) == []


def test_surface_contact_above_cfl_half_is_warned_about_naming_the_key(tmp_path):
    """Particle-to-surface contact's energy error grows with the step (the sphere on the
    block +2.7 % at cfl 0.5, +13.7 % at 0.8): a case that steps above 0.5 with it is
    told so, naming time.cfl; the case at its own 0.5, and a fixed time.dt, are not."""
    sphere = os.path.join(CASES, "sphere_on_fem_block.yaml")
    quick = ["--quiet", "--set", "time.end=0.0002"]
    done = pmpm([sphere, "--out", tmp_path / "fast", *quick, "--set", "time.cfl=0.8"],
                timeout=300)
    assert done.returncode == 0, done.stderr
    assert pmpm_lines(done.stderr) == [
        "pmpm: warning: time.cfl: 0.8 with particle-to-surface contact (FEM body 'block'): "
        "the contact's energy error grows with the step (a steel sphere dropped on an FEM "
        "block gains 2.7 % of its energy at cfl 0.5 and 13.7 % at 0.8; "
        "docs/validation/surface_contact_impact.md); 0.5 or less keeps it within a few "
        "per cent"]
    for name, extra in (("default", []), ("fixed", ["--set", "time.dt=1e-5"])):
        done = pmpm([sphere, "--out", tmp_path / name, *quick, *extra], timeout=300)
        assert done.returncode == 0 and pmpm_lines(done.stderr) == [], done.stderr
