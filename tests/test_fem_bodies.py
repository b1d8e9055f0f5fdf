"""FEM bodies in a run: meshes from a box or a meshio file (rotated), gravity, and the
input they refuse with one line naming the key (exit 2): a mesh without hexahedra, an
inverted element, a missing file, grid contact with an FEM body; the partition over
ranks, 1 rank against 2, and --restart."""
import json
import os

import h5py
import meshio
import numpy as np
import pytest
import yaml

from clihelp import pmpm, pmpm_lines, read_history
from pmpm.case import CaseError, load_case
from pmpm.case.hexmesh import box_mesh, centre_jacobians, hex_mesh
from pmpm.solver.fem_partition import bounding_box, overlapping, partition_mesh, sharers
from pmpm.fem.hexahedron import element_volumes

G = -9.81e-3 * 1000.0        # mm/ms^2, strong so that a few steps move visibly


def case_tree(geometry, **extra):
    tree = {
        "grid": {"min": [-10, -10, -10], "max": [10, 10, 10], "cell": 1.0},
        "gravity": [0, 0, G],
        "materials": {"steel": {"model": "elastic", "density": 7.8e-3, "E": 2e5,
                                "nu": 0.3}},
        "bodies": [{"name": "block", "material": "steel", "method": "fem",
                    "geometry": geometry, "fem": {"element_size": 1.0}}],
        "time": {"end": 0.01},
        "output": {"frames": 2},
    }
    tree.update(extra)
    return tree


def write_case(tmp_path, tree, name="case.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(tree))
    return path


def run_summary(tmp_path, geometry):
    """Run the one-body case of ``geometry``; (output folder, summary.json)."""
    out = tmp_path / "out"
    done = pmpm([write_case(tmp_path, case_tree(geometry)), "--out", out, "--quiet"])
    assert done.returncode == 0, done.stderr
    with open(out / "summary.json") as f:
        return out, json.load(f)


def write_hex_mesh(path, invert=False):
    """A 2 x 2 x 2 block of unit hexahedra in a .vtu file."""
    points, hexes = box_mesh([0, 0, 0], [2, 2, 2], [2, 2, 2])
    if invert:
        hexes[3] = hexes[3][[4, 5, 6, 7, 0, 1, 2, 3]]
    meshio.write(str(path), meshio.Mesh(points, [("hexahedron", hexes)]))


def test_a_rotated_box_mesh_has_positive_elements_and_the_box_volume():
    geometry = {"type": "box", "min": [0, 0, 0], "max": [3, 2, 1],
                "rotate": {"axis": [1, 1, 0], "angle_deg": 37, "origin": [0, 0, 0]}}
    points, hexes = hex_mesh(geometry, 0.5)
    assert hexes.shape == (6 * 4 * 2, 8)
    jac = centre_jacobians(points, hexes)
    assert (jac > 0).all() and 8 * jac.sum() == pytest.approx(6.0, rel=1e-12)


def test_hourglass_coefficient_defaults_follow_the_form(tmp_path):
    geometry = {"type": "box", "min": [0, 0, 0], "max": [2, 2, 2]}
    case = load_case(write_case(tmp_path, case_tree(geometry)))
    assert case["bodies"][0]["fem"] == {"element_size": 1.0, "element": "reduced",
                                        "hourglass": "stiffness",
                                        "hourglass_coefficient": 0.05, "constraints": []}
    tree = case_tree(geometry)
    tree["bodies"][0]["fem"] = {"hourglass": "viscous"}
    case = load_case(write_case(tmp_path, tree, "viscous.yaml"))
    assert case["bodies"][0]["fem"] == {"element_size": 1.0, "element": "reduced",
                                        "hourglass": "viscous",
                                        "hourglass_coefficient": 0.1, "constraints": []}


def test_a_mesh_body_falls_freely_under_gravity(tmp_path):
    """Central differences give v = g t exactly for a free body; the mesh is read with
    meshio, turned by rotate, and reported like a particle body."""
    write_hex_mesh(tmp_path / "block.vtu")
    geometry = {"type": "mesh", "file": "block.vtu", "translate": [-1, -1, -1],
                "rotate": {"axis": [0, 1, 1], "angle_deg": 30}}
    out, summary = run_summary(tmp_path, geometry)
    block = summary["bodies"]["block"]
    assert block["mass"] == pytest.approx(8 * 7.8e-3, rel=1e-12)
    assert block["n_elements"] == 8 and block["n_nodes"] == 27
    assert block["velocity"] == pytest.approx([0, 0, G * summary["t_end"]], abs=1e-12)
    assert block["energy"]["internal"] < 1e-9 * block["energy"]["kinetic"]
    header, rows = read_history(out)
    vz = rows[:, header.index("block.vz")]
    assert vz == pytest.approx(G * rows[:, header.index("time")], abs=1e-12)


@pytest.mark.parametrize("hourglass", ["stiffness", "viscous"])
def test_a_free_ringing_block_keeps_its_momentum_and_energy(tmp_path, hourglass):
    """No gravity, no load, no face touched: the element forces sum to zero node by node
    over each element (sum of b_I = sum of gamma_I = 0), so the momentum stays what it
    was to round-off; the energy (kinetic + internal + hourglass) swings within 3 %
    while the block rings and spins (the balance takes the kinetic energy of the
    half-step velocities; measured: +1.5 % viscous, +2.3 % stiffness at most) and ends
    within 1 % of the start (the stiffness form's hourglass energy is the stored one:
    counted with the end-of-step force alone it made the balance grow 35 %)."""
    geometry = {"type": "box", "min": [-2, -2, -2], "max": [2, 2, 2],
                "rotate": {"axis": [1, 2, 3], "angle_deg": 25}}
    tree = case_tree(geometry, gravity=[0, 0, 0], time={"end": 0.02})
    tree["bodies"][0]["velocity"] = ["3 + 20 * sin(y) - 5 * z", "10 * x * z", "5 * x - y"]
    tree["bodies"][0]["fem"] = {"element_size": 0.5, "hourglass": hourglass}
    out = tmp_path / "out"
    done = pmpm([write_case(tmp_path, tree), "--out", out, "--quiet"])
    assert done.returncode == 0, done.stderr
    header, rows = read_history(out)
    v = rows[:, [header.index(f"block.v{a}") for a in "xyz"]]
    assert np.abs(v - v[0]).max() < 1e-12 * np.abs(v).max()
    with open(out / "summary.json") as f:
        summary = json.load(f)
    balance = summary["energy_balance"]
    assert balance["largest_growth"] < 0.03 and abs(balance["growth"]) < 0.01
    assert summary["energy"]["internal"] > 0.1 * summary["energy"]["total"]  # it rang
    assert summary["energy"]["hourglass"] >= 0


def test_a_rigid_fem_body_keeps_its_velocity(tmp_path):
    """Material `rigid`: no stress, no force, gravity and the fixed face it starts on
    ignored: the block moves with its initial velocity, exactly."""
    geometry = {"type": "box", "min": [0, 0, -10], "max": [2, 2, -8]}
    tree = case_tree(geometry, time={"end": 0.05})
    tree["grid"]["boundary"] = {"z-": "fixed"}
    tree["materials"]["stone"] = {"model": "rigid", "density": 2.5e-3}
    tree["bodies"][0].update(material="stone", velocity=[10, 0, 5])
    out = tmp_path / "out"
    done = pmpm([write_case(tmp_path, tree), "--out", out, "--quiet"])
    assert done.returncode == 0, done.stderr
    header, rows = read_history(out)
    v = rows[:, [header.index(f"block.v{a}") for a in "xyz"]]
    assert np.abs(v - [10, 0, 5]).max() < 1e-12
    x = rows[:, header.index("block.x")]
    assert x == pytest.approx(1.0 + 10 * rows[:, header.index("time")], abs=1e-12)
    with open(out / "summary.json") as f:
        summary = json.load(f)
    assert summary["bodies"]["block"]["energy"]["internal"] == 0.0
    assert summary["bodies"]["block"]["mass"] == pytest.approx(8 * 2.5e-3, rel=1e-12)


@pytest.mark.parametrize("geometry, key, words", [
    ({"type": "mesh", "file": "tets.vtu"}, "bodies[0].geometry.file",
     "no hexahedron cells"),
    ({"type": "mesh", "file": "inverted.vtu"}, "bodies[0].geometry.file",
     "element 3 (of 1 such) is inverted"),
    ({"type": "mesh", "file": "missing.vtu"}, "bodies[0].geometry.file", "no such file"),
    ({"type": "mesh", "file": "mixed.vtu"}, "bodies[0].geometry.file",
     "the mesh holds 1 tetra, 1 wedge cells besides its hexahedra"),
    ({"type": "box", "min": [0, 0, 0], "max": [2, 2, 2]}, "bodies[0].fem.element_size",
     "elements, more than 1e+08"),
])
def test_bad_fem_bodies_are_refused_with_one_line(tmp_path, geometry, key, words):
    write_hex_mesh(tmp_path / "inverted.vtu", invert=True)
    tet = meshio.Mesh(np.eye(4, 3), [("tetra", np.array([[0, 1, 2, 3]]))])
    meshio.write(str(tmp_path / "tets.vtu"), tet)
    write_mixed_mesh(tmp_path / "mixed.vtu")
    tree = case_tree(geometry)
    if key.endswith("element_size"):
        tree["bodies"][0]["fem"]["element_size"] = 1e-6
    with pytest.raises(CaseError) as error:
        load_case(write_case(tmp_path, tree))
    [line] = error.value.problems
    assert line.startswith(key + ":") and words in line, line


def write_mixed_mesh(path):
    """The 2 x 2 x 2 block with a tetrahedron and a wedge on top, and a quad face (a
    surface cell, which is ignored)."""
    points, hexes = box_mesh([0, 0, 0], [2, 2, 2], [2, 2, 2])
    top = np.flatnonzero(points[:, 2] == 2)[:4]
    points = np.vstack([points, [[0, 0, 3], [1, 0, 3]]])
    n = len(points)
    meshio.write(str(path), meshio.Mesh(points, [
        ("hexahedron", hexes), ("tetra", np.array([[top[0], top[1], top[3], n - 2]])),
        ("wedge", np.array([[top[0], top[1], top[2], n - 2, n - 1, n - 1]])),
        ("quad", hexes[:1, :4])]))


def test_a_mesh_of_hexahedra_and_surface_cells_is_taken(tmp_path):
    """Surface cells (a quad face) beside the hexahedra are ignored, not refused."""
    points, hexes = box_mesh([0, 0, 0], [2, 2, 2], [2, 2, 2])
    meshio.write(str(tmp_path / "faces.vtu"),
                 meshio.Mesh(points, [("hexahedron", hexes), ("quad", hexes[:, :4])]))
    case = load_case(write_case(tmp_path, case_tree({"type": "mesh", "file": "faces.vtu"})))
    assert case["bodies"][0]["method"] == "fem"


def write_inp_with_base_set(path):
    """The 2 x 2 x 2 block as an Abaqus file with the node set BASE (its z = 0 nodes)."""
    points, hexes = box_mesh([0, 0, 0], [2, 2, 2], [2, 2, 2])
    base = np.flatnonzero(points[:, 2] == 0)
    meshio.write(str(path), meshio.Mesh(points, [("hexahedron", hexes)],
                                        point_sets={"BASE": base}))
    return points, base


@pytest.mark.parametrize("choose", ["node_set", "region"])
def test_constrained_nodes_hold_while_the_rest_falls(tmp_path, choose):
    """A block clamped at its base by a node set of its Abaqus file, or by a box, under
    gravity: the base nodes do not move; the top settles by about the static
    rho g H^2 / 2E (a dynamic load: up to twice that), not the free fall's g t^2 / 2,
    150 times more."""
    points, base = write_inp_with_base_set(tmp_path / "block.inp")
    constraint = {"node_set": "BASE"} if choose == "node_set" else \
        {"region": {"min": [-1, -1, -0.1], "max": [3, 3, 0.1]}}
    tree = case_tree({"type": "mesh", "file": "block.inp"}, time={"end": 0.005})
    tree["bodies"][0]["fem"]["constraints"] = [{**constraint, "fix": ["x", "y", "z"]}]
    out = tmp_path / "out"
    done = pmpm([write_case(tmp_path, tree), "--out", out, "--quiet"])
    assert done.returncode == 0, done.stderr
    with h5py.File(out / "elements.h5") as f:
        last = f["frames"][sorted(f["frames"])[-1]]
        x = last["node_x"][:]
    assert (x[base] == points[base]).all()
    static = 7.8e-3 * abs(G) * 2.0 ** 2 / (2 * 2e5)
    sag = 2.0 - x[points[:, 2] == 2, 2]
    assert (sag > 0.2 * static).all() and (sag < 2.5 * static).all(), sag / static


@pytest.mark.parametrize("constraint, key, words", [
    ({"node_set": "TOP", "fix": ["z"]}, "bodies[0].fem.constraints[0].node_set",
     "unknown node set 'TOP'; known: BASE"),
    ({"fix": ["z"]}, "bodies[0].fem.constraints[0]",
     "give exactly one of 'region' and 'node_set'"),
    ({"node_set": "BASE", "fix": ["w"]}, "bodies[0].fem.constraints[0].fix[0]", "w"),
])
def test_bad_constraints_are_refused(tmp_path, constraint, key, words):
    write_inp_with_base_set(tmp_path / "block.inp")
    tree = case_tree({"type": "mesh", "file": "block.inp"})
    tree["bodies"][0]["fem"]["constraints"] = [constraint]
    with pytest.raises(CaseError) as error:
        load_case(write_case(tmp_path, tree))
    [line] = error.value.problems
    assert line.startswith(key + ":") and words in line, line


def test_a_constraint_region_without_nodes_stops_at_set_up(tmp_path):
    tree = case_tree({"type": "box", "min": [0, 0, 0], "max": [2, 2, 2]})
    tree["bodies"][0]["fem"]["constraints"] = [
        {"region": {"min": [5, 5, 5], "max": [6, 6, 6]}, "fix": ["x"]}]
    done = pmpm([write_case(tmp_path, tree), "--out", tmp_path / "out"])
    assert done.returncode == 2
    assert pmpm_lines(done.stderr) == ["pmpm: error: bodies[0].fem.constraints[0]: selects "
                                       "no node of body 'block'"]


def test_an_fem_body_on_a_face_with_friction_stops_at_set_up(tmp_path):
    tree = case_tree({"type": "box", "min": [0, 0, -10], "max": [2, 2, -8]})
    tree["grid"].update(boundary={"z-": "slip"}, friction={"z-": 0.3})
    done = pmpm([write_case(tmp_path, tree), "--out", tmp_path / "out"])
    assert done.returncode == 2
    [line] = pmpm_lines(done.stderr)
    assert line.startswith("pmpm: error: grid.friction.z-: nodes of an FEM body lie on "
                           "this face"), line


def coupled_tree(contact):
    geometry = {"type": "box", "min": [0, 0, 0], "max": [2, 2, 2]}
    tree = case_tree(geometry)
    tree["bodies"].append({"name": "ball", "material": "steel",
                           "geometry": {"type": "sphere", "center": [0, 0, -5],
                                        "radius": 2}})
    tree["contact"] = contact
    return tree


@pytest.mark.parametrize("contact, problem", [
    ({"coupling": "grid"}, "contact.coupling: grid coupling (CFEMP) puts the FE nodes into "
                           "the multi-velocity grid contact: set contact.method to 1 or 2, "
                           "or use surface coupling"),
    ({"pairs": [{"bodies": ["ball", "block"], "coupling": "grid"}]},
     "contact.pairs[0].coupling: grid coupling (CFEMP) needs contact.method 1 or 2"),
    ({"method": 2, "pairs": [{"bodies": ["ball", "block"], "normal": "ball"}]},
     "contact.pairs[0].normal: in surface coupling the FEM body 'block' is the master: its "
     "faces give the normal, not the particle body 'ball'"),
    ({"coupling": "wedge"}, "contact.coupling: unknown coupling 'wedge'; known: grid, surface"),
])
def test_a_coupling_that_cannot_be_made_is_refused_naming_its_key(tmp_path, contact,
                                                                   problem):
    with pytest.raises(CaseError) as error:
        load_case(write_case(tmp_path, coupled_tree(contact)))
    assert error.value.problems == [problem]


def test_coupling_codes_follow_the_section_and_the_pairs(tmp_path):
    from pmpm.solver.bodies import BodyTable
    from pmpm.solver.contact import GRID_COUPLING, SURFACE_COUPLING, ContactRules
    tree = coupled_tree({"method": 1, "coupling": "grid"})
    tree["bodies"].append({"name": "rod", "material": "steel",
                           "geometry": {"type": "sphere", "center": [0, 0, 5],
                                        "radius": 1}})
    tree["bodies"].append({"name": "plate", "material": "steel", "method": "fem",
                           "geometry": {"type": "box", "min": [5, 5, 5], "max": [7, 7, 6]},
                           "fem": {"element_size": 1.0}})
    tree["contact"]["pairs"] = [{"bodies": ["rod", "plate"], "coupling": "surface"},
                                {"bodies": ["ball", "plate"], "coupling": "surface"}]
    from pmpm.case import load_config
    config = load_config(write_case(tmp_path, tree))
    rules = ContactRules(config.contact, BodyTable(config),
                         [b.method == "fem" for b in config.bodies])
    block, ball, rod, plate = (config.bodies.index(b) for b in config.bodies
                               if b.name in ("block", "ball", "rod", "plate"))
    assert rules.coupling[block, ball] == rules.coupling[ball, block] == GRID_COUPLING
    assert rules.coupling[block, rod] == GRID_COUPLING
    assert rules.coupling[plate, rod] == rules.coupling[rod, plate] == SURFACE_COUPLING
    assert rules.coupling[ball, rod] == 0
    # two FEM bodies take the section's coupling too: on the grid (AFEMP)
    assert rules.coupling[block, plate] == rules.coupling[plate, block] == GRID_COUPLING


@pytest.mark.parametrize("method, pairs, key", [
    (2, [], "contact.method"),
    (0, [{"bodies": ["block", "plate"], "coupling": "grid"}], "contact.pairs[0].coupling"),
    (2, [{"bodies": ["block", "plate"]}], "contact.pairs[0].coupling"),
])
def test_two_fem_bodies_on_the_grid_need_method_1_naming_the_key(tmp_path, method, pairs,
                                                                  key):
    """Under method 2 the start correction takes the approach out of velocities the FE
    nodes never take: two FEM bodies on the grid would pass through each other (an ogive
    rod through its plate at 575 m/s, untouched), so the case is refused."""
    from pmpm.case.fem import FEM_PAIR_ON_GRID
    tree = coupled_tree({"method": method, "coupling": "grid" if method else "surface"})
    tree["bodies"].append({"name": "plate", "material": "steel", "method": "fem",
                           "geometry": {"type": "box", "min": [5, 5, 5], "max": [7, 7, 6]},
                           "fem": {"element_size": 1.0}})
    tree["contact"]["pairs"] = pairs
    with pytest.raises(CaseError) as error:
        load_case(write_case(tmp_path, tree))
    assert f"{key}: {FEM_PAIR_ON_GRID}" in error.value.problems


def test_an_fem_body_met_on_the_grid_and_by_surface_contact_is_refused_in_validation(
        tmp_path):
    """Issue 27: found during validation (before: SetupError 25 s into the set-up, after
    meshing and filling every body)."""
    tree = coupled_tree({"method": 2, "coupling": "grid"})
    tree["bodies"].append({"name": "rod", "material": "steel",
                           "geometry": {"type": "sphere", "center": [0, 0, 5],
                                        "radius": 1}})
    tree["contact"]["pairs"] = [{"bodies": ["rod", "block"], "coupling": "surface"}]
    with pytest.raises(CaseError) as error:
        load_case(write_case(tmp_path, tree))
    assert error.value.problems == [
        "contact.pairs[0].coupling: FEM body 'block' would meet ball on the grid and rod "
        "by surface contact; give all its pairs one coupling"]


def test_partition_owns_each_element_once_and_shares_nodes_symmetrically():
    points, hexes = box_mesh([0, 0, 0], [3, 2, 2], [6, 2, 3])
    owner = np.random.default_rng(0).integers(0, 3, len(hexes))
    parts = [partition_mesh(hexes, len(points), owner, r, 3) for r in range(3)]
    assert sorted(np.concatenate([p.elements for p in parts])) == list(range(len(hexes)))
    owned = np.concatenate([p.nodes[p.owned] for p in parts])
    assert sorted(owned) == list(range(len(points)))
    for r, part in enumerate(parts):
        assert (part.nodes[part.hexes] == hexes[part.elements]).all()
        for other, local in part.partners:
            back = dict(parts[other].partners)[r]
            assert (part.nodes[local] == parts[other].nodes[back]).all()
    used = np.zeros((3, len(points)), bool)      # the rank-by-node table, as reference
    for r in range(3):
        used[r, hexes[owner == r].ravel()] = True
    for r, part in enumerate(parts):
        assert (part.nodes == np.flatnonzero(used[r])).all()
        assert (part.owned == (np.argmax(used[:, part.nodes], axis=0) == r)).all()
        expected = [q for q in range(3) if q != r and (used[r] & used[q]).any()]
        assert [q for q, _ in part.partners] == expected
        for q, local in part.partners:
            assert (part.nodes[local] == np.flatnonzero(used[r] & used[q])).all()
    boxes = [bounding_box(points[p.nodes]) for p in parts]
    for r, part in enumerate(parts):        # after a migration, from the ranks' node ids
        near = overlapping(boxes, r, 0.0)
        partners, owned = sharers(part.nodes, r, {q: parts[q].nodes for q in near})
        assert [q for q, _ in partners] == [q for q, _ in part.partners]
        assert all((a == b).all() for (_, a), (_, b) in zip(partners, part.partners))
        assert (owned == part.owned).all()


def test_node_ids_go_only_to_ranks_whose_nodes_box_meets_this_ones():
    boxes = [bounding_box(np.array([[x, 0, 0], [x + 1, 1, 1]], float)) for x in (0, 1, 3)]
    boxes.append(bounding_box(np.zeros((0, 3))))             # a rank without nodes
    assert [overlapping(boxes, r, 0.0) for r in range(4)] == [[1], [0], [], []]
    assert overlapping(boxes, 1, 0.5) == [0, 2]


def test_two_ranks_give_the_one_rank_answer(tmp_path):
    """The copper block of runs/fem_block.yaml (Johnson-Cook, viscous hourglass control)
    hitting a wall, 8 x 8 x 8 elements: the slab plane cuts the mesh, and the nodes on it
    are shared."""
    case = os.path.join(os.path.dirname(__file__), "..", "runs", "fem_block.yaml")
    sets = ["--set", "params.edge=4", "--set", "time.end=0.002", "--quiet"]
    frames = []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        done = pmpm([case, "--out", out, *sets], ranks=ranks)
        assert done.returncode == 0, done.stderr
        with h5py.File(out / "elements.h5") as f:
            last = f["frames"][sorted(f["frames"])[-1]]
            frames.append({k: last[k][:] for k in ("node_x", "node_v", "stress")})
        with open(out / "summary.json") as f:
            summary = json.load(f)
        assert summary["n_elements"] == 512
        assert len(summary["elements_per_rank"]) == ranks
        assert min(summary["elements_per_rank"]) > 0   # the slab plane cuts the mesh
    one, two = frames
    assert np.abs(one["node_x"] - two["node_x"]).max() < 1e-10 * 4.0
    assert np.abs(one["node_v"] - two["node_v"]).max() < 1e-10 * 190.0
    scale = np.abs(one["stress"]).max()
    assert scale > 100.0                               # it did hit the wall
    assert np.abs(one["stress"] - two["stress"]).max() < 1e-10 * scale


def test_elements_migrate_with_their_slab_and_two_ranks_match_one(tmp_path):
    """A bar of 192 elements flies 8 mm along x (and rings, from a sine velocity) across
    the slab plane, the balance checked every 5 steps: the slabs follow the bar, its
    elements move to the rank of their centroid with their state, and the frames equal
    the one-rank run's to round-off."""
    tree = {"grid": {"min": [0, 0, 0], "max": [20, 4, 4], "cell": 1.0},
            "materials": {"steel": {"model": "elastic", "density": 7.8e-3, "E": 2e5,
                                    "nu": 0.3}},
            "bodies": [{"name": "bar", "material": "steel", "method": "fem",
                        "geometry": {"type": "box", "min": [2, 1, 1], "max": [8, 3, 3]},
                        "velocity": [500, 0, "20 * sin(x)"],
                        "fem": {"element_size": 0.5, "hourglass": "viscous"}}],
            "time": {"end": 0.016}, "decomposition": {"check_every": 5},
            "output": {"frames": 2}}
    case = write_case(tmp_path, tree)
    frames, summaries = [], []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        done = pmpm([case, "--out", out, "--quiet"], ranks=ranks)
        assert done.returncode == 0, done.stderr
        with h5py.File(out / "elements.h5") as f:
            last = f["frames"][sorted(f["frames"])[-1]]
            frames.append({k: last[k][:] for k in ("node_x", "node_v", "stress")})
        with open(out / "summary.json") as f:
            summaries.append(json.load(f))
    bar = summaries[1]["bodies"]["bar"]
    assert bar["bbox_min"][0] > 9.5                       # it crossed the first plane, x = 5
    plane = summaries[1]["slabs"]["bounds"][1]
    assert bar["bbox_min"][0] < plane < bar["bbox_max"][0]
    assert summaries[1]["elements_per_rank"] == [96, 96]  # each half on its slab's rank
    one, two = frames
    for key, scale in (("node_x", 20.0), ("node_v", 500.0)):
        assert np.abs(one[key] - two[key]).max() < 1e-10 * scale
    assert np.abs(one["stress"] - two["stress"]).max() < 1e-10 * np.abs(one["stress"]).max()


@pytest.mark.parametrize("shape", ["linear", "gimp"])
def test_particles_and_elements_in_one_run_on_one_and_two_ranks(tmp_path, shape):
    """A particle rod on the fixed face x- and an FEM bar clear of it (not coupled),
    slip faces around, gravity along -x: every column of history.csv is the same on 1
    and 2 ranks; the FEM bar falls freely."""
    tree = case_tree({"type": "box", "min": [12, 0, 0], "max": [20, 2, 2]},
                     gravity=[-9.81, 0, 0], time={"end": 0.004})
    tree["grid"] = {"min": [0, 0, 0], "max": [20, 2, 2], "cell": 1.0,
                    "shape_functions": shape,
                    "boundary": {"x-": "fixed", "y-": "slip", "y+": "slip", "z-": "slip",
                                 "z+": "slip"}}
    tree["bodies"].append({"name": "rod", "material": "steel",
                           "geometry": {"type": "box", "min": [0, 0, 0], "max": [8, 2, 2]}})
    case = write_case(tmp_path, tree)
    histories = []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        done = pmpm([case, "--out", out, "--quiet"], ranks=ranks)
        assert done.returncode == 0, done.stderr
        histories.append(read_history(out))
        with open(out / "summary.json") as f:
            summary = json.load(f)
        assert summary["bodies"]["rod"]["n_particles"] == 8 * 2 * 2 * 8
        assert summary["bodies"]["block"]["n_elements"] == 32
    (header, one), (_, two) = histories
    assert np.abs(one - two).max() < 1e-10 * np.abs(one).max()
    t, block = one[:, header.index("time")], one[:, header.index("block.vx")]
    assert block == pytest.approx(-9.81 * t, abs=1e-12)   # the FEM bar falls freely
    rod = one[:, header.index("rod.vx")]
    assert np.abs(rod).max() > 0                          # the fixed rod rings


def last_element_frame(out):
    with h5py.File(out / "elements.h5") as f:
        names = sorted(f["frames"])
        last = f["frames"][names[-1]]
        return len(names), {k: last[k][:] for k in ("node_x", "node_v", "stress")}


@pytest.mark.parametrize("ranks", [1, 2])
def test_restart_ends_where_the_uninterrupted_run_does(tmp_path, ranks):
    """The FEM bar of runs/fem_wave_bar.yaml stopped at 15.6 us and continued to 41.6 us
    with --restart (on 1 rank, or 2 from the 1-rank checkpoint) ends as the run that was
    not stopped: bit for bit on 1 rank, to round-off on 2; the frames before the
    checkpoint are kept."""
    case = os.path.join(os.path.dirname(__file__), "..", "runs", "fem_wave_bar.yaml")
    sets = ["--set", "params.element=1", "--set", "params.width=2", "--set",
            "output.times=[0.0076,0.0156]", "--quiet"]
    full, part = tmp_path / "full", tmp_path / "part"
    assert pmpm([case, "--out", full, *sets]).returncode == 0
    assert pmpm([case, "--out", part, *sets, "--set", "time.end=0.0156"]).returncode == 0
    done = pmpm([case, "--out", part, "--restart", *sets], ranks=ranks)
    assert done.returncode == 0, done.stderr
    with open(part / "summary.json") as f:
        per_rank = json.load(f)["elements_per_rank"]
    assert len(per_rank) == ranks and min(per_rank) > 0  # 2 ranks: both hold elements
    (n_full, one), (n_part, two) = last_element_frame(full), last_element_frame(part)
    assert n_full == n_part == 4
    for key in one:
        if ranks == 1:
            assert (one[key] == two[key]).all(), key
        else:
            assert np.abs(one[key] - two[key]).max() < 1e-10 * np.abs(one[key]).max()


def thrown_block(vx, x_face="slip"):
    """A 2 x 2 x 2 block 4 mm from the face x+ (and 4 mm from x-), no gravity, thrown
    along x at ``vx``."""
    tree = case_tree({"type": "box", "min": [-6, -1, -1], "max": [-4, 1, 1]},
                     gravity=[0, 0, 0], time={"end": 0.02})
    tree["grid"].update({"min": [-10, -4, -4], "max": [0, 4, 4],
                         "boundary": {"x+": x_face}})
    tree["bodies"][0]["velocity"] = [vx, 0, 0]
    return tree


def test_a_block_thrown_at_a_slip_face_stops_there(tmp_path):
    """Not on the face at t = 0, it reaches it after 8 us: its nodes land on the face
    and stay on or inside it (before, the face held only the nodes on it at set-up, and
    the block flew through); it is pushed back by its own rebound. 2 ranks (both holding
    elements) end as 1 does, to round-off."""
    tree = thrown_block(500.0)
    tree["output"] = {"times": [0.004, 0.008, 0.012, 0.016]}
    # slabs of one cell, so that the rebalanced slabs still split the block at the face
    # (the 27-node shapes keep slabs 3 cells wide)
    tree["grid"]["shape_functions"] = "linear"
    case, frames = write_case(tmp_path, tree), []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        done = pmpm([case, "--out", out, "--quiet"], ranks=ranks)
        assert done.returncode == 0, done.stderr
        with open(out / "summary.json") as f:
            per_rank = json.load(f)["elements_per_rank"]
        assert len(per_rank) == ranks and min(per_rank) > 0
        with h5py.File(out / "elements.h5") as f:
            frames.append([f["frames"][name]["node_x"][:] for name in sorted(f["frames"])])
    xs = [x[:, 0] for x in frames[0]]
    assert max(x.max() for x in xs) <= 1e-9
    assert any(x.max() > -1e-9 for x in xs)               # it did reach the face
    assert max(np.abs(a - b).max() for a, b in zip(*frames)) < 1e-10 * 10.0
    header, rows = read_history(tmp_path / "r1")
    assert rows[-1, header.index("block.vx")] < 0.5 * 500.0


def test_a_block_thrown_out_through_a_free_face_is_a_fault(tmp_path):
    done = pmpm([write_case(tmp_path, thrown_block(-500.0)), "--out", tmp_path / "out"])
    assert done.returncode == 1
    assert "of FEM body 'block' has left the grid box through the free face x-" \
        in done.stderr, done.stderr


def test_constrained_components_start_at_rest(tmp_path):
    """Initial velocity [5, 5, -3] on a block standing on the slip face z- with its
    nodes at x = 0 held in x: at t = 0 those nodes have vx = 0 and the base nodes
    vz = 0, and the kinetic energy of the first history row counts only what is free."""
    tree = case_tree({"type": "box", "min": [0, 0, -10], "max": [2, 2, -8]},
                     gravity=[0, 0, 0])
    tree["grid"]["boundary"] = {"z-": "slip"}
    tree["bodies"][0]["velocity"] = [5, 5, -3]
    tree["bodies"][0]["fem"]["constraints"] = [
        {"region": {"min": [-0.1, -1, -11], "max": [0.1, 3, -7]}, "fix": ["x"]}]
    out = tmp_path / "out"
    done = pmpm([write_case(tmp_path, tree), "--out", out, "--quiet"])
    assert done.returncode == 0, done.stderr
    with h5py.File(out / "elements.h5") as f:
        first = f["frames"][sorted(f["frames"])[0]]
        x, v = first["node_x"][:], first["node_v"][:]
    held, base = x[:, 0] == 0, x[:, 2] == -10
    assert (v[held, 0] == 0).all() and (v[~held, 0] == 5).all()
    assert (v[base, 2] == 0).all() and (v[~base, 2] == -3).all()
    header, rows = read_history(out)
    held_share = 0.25                   # of the lumped mass: a face of nodes of the block
    kinetic = 0.5 * 8 * 7.8e-3 * (25 + 25 + 9 - held_share * 25 - held_share * 9)
    assert rows[0, header.index("kinetic")] == pytest.approx(kinetic, rel=1e-12)


@pytest.mark.parametrize("geometry, volume", [
    ({"type": "sphere", "center": [1, 2, 3], "radius": 5.0}, 4 / 3 * np.pi * 125),
    ({"type": "cylinder", "base": [0, 0, 0], "axis": "y", "radius": 5.0, "length": 10.0,
      "inner_radius": 0.0}, np.pi * 25 * 10),
    ({"type": "cylinder", "base": [0, 0, 0], "axis": "x", "radius": 5.0, "length": 10.0,
      "inner_radius": 3.0}, np.pi * 16 * 10),
])
@pytest.mark.parametrize("size", [1.0, 0.5])
def test_sphere_and_cylinder_meshes_fill_their_shape_with_sound_elements(geometry, volume,
                                                                       size):
    """The cubed sphere, the O-grid cylinder and the polar tube: every element's centre
    Jacobian positive, the volume within 1.2 % (the faces are flat), the smallest
    element's characteristic length (volume / largest face, the time step's) at least
    0.35 of the element size, every node inside the shape."""
    from pmpm.fem.hexahedron import element_geometry
    points, hexes = hex_mesh(geometry, size)
    assert (centre_jacobians(points, hexes) > 0).all()
    vols = np.empty(len(hexes))
    element_volumes(points, hexes, vols)
    assert abs(vols.sum() / volume - 1) < 0.012
    b = np.empty((8, 3))
    shortest = min(v / element_geometry(points[h], b)[1] for v, h in zip(vols, hexes))
    assert shortest > 0.35 * size
    assert len(np.unique(hexes)) == len(points)            # no loose node, seam merged
    if geometry["type"] == "sphere":
        r = np.linalg.norm(points - geometry["center"], axis=1)
        assert r.max() == pytest.approx(5.0) and r.min() == pytest.approx(0.0)
    else:
        a = "xyz".index(geometry["axis"])
        radial = np.linalg.norm(np.delete(points, a, axis=1), axis=1)
        assert radial.max() == pytest.approx(5.0)
        assert radial.min() == pytest.approx(geometry["inner_radius"])
        assert np.ptp(points[:, a]) == pytest.approx(10.0)


def test_an_fem_sphere_falls_freely_and_weighs_its_elements(tmp_path):
    """A cubed-sphere body from the case's sphere geometry, rotated: v = g t exactly, and
    its mass is rho times the sum of its element volumes (3 % under the sphere's, at 6
    elements across)."""
    geometry = {"type": "sphere", "center": [0, 0, 0], "radius": 3.0,
                "rotate": {"axis": [1, 1, 0], "angle_deg": 20}}
    _, summary = run_summary(tmp_path, geometry)
    block = summary["bodies"]["block"]
    points, hexes = hex_mesh(geometry | {"rotate": None}, 1.0)
    vols = np.empty(len(hexes))
    element_volumes(points, hexes, vols)
    assert block["mass"] == pytest.approx(7.8e-3 * vols.sum(), rel=1e-12)
    assert block["mass"] == pytest.approx(7.8e-3 * 4 / 3 * np.pi * 27, rel=0.04)
    assert block["n_elements"] == 6 ** 3
    assert block["velocity"] == pytest.approx([0, 0, G * summary["t_end"]], abs=1e-12)


def test_no_rank_keeps_the_whole_mesh_once_the_run_is_set_up(tmp_path, monkeypatch):
    """The whole meshes built at set-up (and the checkpoint's FEM groups read whole on a
    restart) are freed before the time loop: each rank then holds only its elements
    and their nodes."""
    import gc
    import weakref

    from mpi4py import MPI

    import pmpm.app
    import pmpm.solver.simulation
    from pmpm.__main__ import parse_args
    from pmpm.comm import World
    from pmpm.solver.run import Runner
    whole, alive = [], []
    build, read, run = (pmpm.solver.simulation.build_meshes, pmpm.app.read_fem_groups,
                        Runner.run)

    def building(*args):
        meshes = build(*args)
        whole.extend(weakref.ref(m.points) for m in meshes.values())
        return meshes

    def reading(*args):
        groups, problem = read(*args)
        whole.extend(weakref.ref(col) for rows in groups.values() for col in rows.values())
        return groups, problem

    def running(self, **kwargs):
        gc.collect()
        alive.append(sum(ref() is not None for ref in whole))
        return run(self, **kwargs)
    monkeypatch.setattr(pmpm.solver.simulation, "build_meshes", building)
    monkeypatch.setattr(pmpm.app, "read_fem_groups", reading)
    monkeypatch.setattr(Runner, "run", running)
    case = write_case(tmp_path, case_tree({"type": "box", "min": [-2, -2, -2],
                                           "max": [2, 2, 2]}))
    out = str(tmp_path / "out")
    for argv in ([case, "--out", out, "--quiet", "--set", "time.end=0.004"],
                 [case, "--out", out, "--quiet", "--restart"]):
        pmpm.app.run_case(World(MPI.COMM_SELF), parse_args([str(a) for a in argv]))
    assert len(whole) > 2 and alive == [0, 0]


def test_a_body_of_converted_elements_gets_its_fem_bodys_share_of_lost_mass():
    """Under grid coupling a converting FEM body's particles are a body of their own,
    empty at the start: its lost-mass allowance is a share of its FEM body's mass (it
    was of 0: the first fragment to leave stopped the 2 mm AFEMP perforation)."""
    from pmpm.case.loader import load_config
    from pmpm.solver.run import initial_masses
    case = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "runs",
                        "ogive_plate_fem.yaml")
    config = load_config(case, ["contact.coupling=grid", "contact.method=1"])
    names = [b.name for b in config.bodies]
    assert names == ["rod", "plate", "rod_converted", "plate_converted"]
    assert [b.born_of for b in config.bodies] == [None, None, "rod", "plate"]
    stats = {"rod": {"mass": 81.0}, "plate": {"mass": 860.0},
             "rod_converted": {"mass": 0.0}, "plate_converted": {"mass": 0.0}}
    mass0 = initial_masses(config, names, stats, np.zeros(4))
    assert mass0.tolist() == [81.0, 860.0, 81.0, 860.0]
    assert [b.name for b in load_config(case).bodies] == ["rod", "plate"]    # IAFEMP


def test_a_body_named_as_a_converted_body_is_refused_naming_its_key():
    from pmpm.case.loader import load_config
    case = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "runs",
                        "ogive_plate_fem.yaml")
    with pytest.raises(CaseError) as error:
        load_config(case, ["contact.coupling=grid", "contact.method=1",
                           "bodies[0].name=plate_converted"])
    assert error.value.problems == [
        "bodies[0].name: 'plate_converted' is the body that FEM body 'plate' (bodies[1]) "
        "converts into on the grid; choose another name"]
