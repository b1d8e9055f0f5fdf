"""Tied interface grid MPM (seed 000 Secs. 3-4): refined windows, the tied interface,
windows that follow a body, particle splitting; case checks, kernels, conservation, and
1 rank against 2 ranks."""
import os

import numpy as np
import pytest

from pmpm.case import CaseError, fill_body, validate_case
from pmpm.grid import Window
from pmpm.kernels import tied
from pmpm.kernels.records import NodeBlock, TieSet
from pmpm.particles import Particles
from pmpm.particles.split import split, sub_cube_offsets
from pmpm.post import axial_profiles, read_frame, read_summary, rms_error, wave_bar_stress
from runhelp import CASES, RUNS, run_pmpm

FOLLOW = os.path.join(CASES, "window_follow.yaml")
WAVE = os.path.join(RUNS, "wave_bar.yaml")


def case_with_window(**window):
    raw = {"grid": {"min": [0, 0, 0], "max": [10, 4, 4], "cell": 1.0,
                    "windows": [dict({"min": [4, 0, 0], "max": [8, 4, 4], "ratio": 2},
                                     **window)]},
           "materials": {"steel": {"model": "elastic", "density": 7.85e-3, "E": 2e5,
                                   "nu": 0.3}},
           "bodies": [{"name": "bar", "material": "steel",
                       "geometry": {"type": "box", "min": [0, 0, 0], "max": [10, 4, 4]}}],
           "time": {"end": 1e-3}}
    return raw


def problems_of(raw):
    with pytest.raises(CaseError) as error:
        validate_case(raw)
    return error.value.problems


# ---------------------------------------------------------------- case file

@pytest.mark.parametrize("window, expected", [
    ({"min": [4.5, 0, 0]}, "grid.windows[0].min[0]: 4.5 is not on a coarse grid line"),
    ({"ratio": 0}, "grid.windows[0].ratio: must be >= 1, got 0"),
    ({"ratio": 2.5}, "grid.windows[0].ratio: expected a whole number"),
    ({"follow": "rod"}, "grid.windows[0].follow: unknown body 'rod'; known: bar"),
    ({"max": [12, 4, 4]}, "grid.windows[0]: outside the grid box along x"),
    ({"max": [3, 4, 4]}, "grid.windows[0]: min must be < max"),
    ({"size": 3}, "grid.windows[0].size: unknown key"),
])
def test_bad_windows_are_reported_with_their_key(window, expected):
    assert any(p.startswith(expected) for p in problems_of(case_with_window(**window)))


def test_overlapping_and_touching_windows_are_reported():
    raw = case_with_window()
    raw["grid"]["windows"].append({"min": [0, 0, 0], "max": [4, 2, 2], "ratio": 2})
    assert problems_of(raw) == ["grid.windows[1]: overlaps or touches grid.windows[0]; "
                                "leave at least one coarse cell between windows"]


def test_cli_reports_a_bad_window_with_exit_2(tmp_path):
    done = run_pmpm(FOLLOW, tmp_path / "out", sets=["grid.windows.0.ratio=0"], check=False)
    assert done.returncode == 2
    assert "grid.windows[0].ratio: must be >= 1, got 0" in done.stderr
    assert "Traceback" not in done.stderr


def test_particles_inside_a_window_get_its_spacing():
    case = validate_case(case_with_window(ratio=3))
    x, vol = fill_body(case["bodies"][0], case["grid"])
    inside = (x[:, 0] > 4) & (x[:, 0] < 8)
    assert inside.sum() == 4 * 4 * 4 * 6 ** 3            # 64 cells of 6^3 particles
    assert (~inside).sum() == 6 * 4 * 4 * 2 ** 3
    assert np.allclose(vol[inside], (1 / 6) ** 3) and np.allclose(vol[~inside], 0.125)
    assert vol.sum() == pytest.approx(160.0)


# ---------------------------------------------------------------- kernels

def node_block(block):
    """The NodeBlock record of a LocalBlock (no box faces: the ties do not read them)."""
    return NodeBlock(block.shape, block.lo, block.strides, np.full(3, 10 ** 6),
                     np.zeros(6, np.int64), np.zeros(block.n_nodes, np.uint16), np.zeros(6))


def test_ties_interpolate_on_the_coarse_faces_and_carry_mass_to_the_masters():
    """A window of coarse cells 1..2 (ratio 2) in a 4 x 3 x 3 box with coarse particles
    everywhere outside: every window face node is tied, its weights are the coarse
    trilinear weights at its position and sum to 1, and mapping moves mass without loss."""
    from pmpm.grid import LocalBlock
    c_block = LocalBlock(np.zeros(3, np.int64), np.array([5, 4, 4]), 0, [])
    w_block = LocalBlock(np.array([2, 0, 0]), np.array([3, 7, 7]), 0, [])  # nodes x 2..4
    occupied = np.ones(c_block.n_nodes, np.int64)
    n = w_block.n_nodes
    slaves, masters, weights = np.empty(n, np.int64), np.empty((n, 8), np.int64), np.empty((n, 8))
    count = tied.find_ties(node_block(w_block), np.array([2, 0, 0]), np.array([4, 6, 6]), 2,
                           node_block(c_block), occupied, TieSet(slaves, masters, weights, 0))
    assert count == n - 1 * 5 * 5                   # all but the 5 x 5 interior of x = 3
    assert np.allclose(weights[:count].sum(axis=1), 1.0)
    # the slave at level node (3, 1, 6): coarse (1.5, 0.5, 3): on the face z = 3
    local = (3 - 2) * w_block.strides[0] + 1 * w_block.strides[1] + 6 * w_block.strides[2]
    row = int(np.flatnonzero(slaves[:count] == local)[0])
    used = masters[row] >= 0
    coarse_nodes = {tuple(np.unravel_index(m, (5, 4, 4))): w
                    for m, w in zip(masters[row][used], weights[row][used])}
    assert coarse_nodes == pytest.approx({(1, 0, 3): 0.25, (1, 1, 3): 0.25, (2, 0, 3): 0.25,
                                          (2, 1, 3): 0.25})
    fine = np.random.default_rng(0).uniform(1, 2, (n, 4))
    coarse = np.zeros((c_block.n_nodes, 4))
    tied.slaves_to_masters(TieSet(slaves, masters, weights, count), fine, coarse)
    assert coarse.sum(axis=0) == pytest.approx(fine[slaves[:count]].sum(axis=0), rel=1e-13)


def test_a_face_without_coarse_particles_beside_it_is_not_tied():
    from pmpm.grid import LocalBlock
    c_block = LocalBlock(np.zeros(3, np.int64), np.array([5, 4, 4]), 0, [])
    w_block = LocalBlock(np.array([2, 0, 0]), np.array([3, 7, 7]), 0, [])
    occupied = np.zeros(c_block.n_nodes, np.int64).reshape(5, 4, 4)
    occupied[:2] = 1                                 # coarse particles only at x < 1
    n = w_block.n_nodes
    out = np.empty(n, np.int64), np.empty((n, 8), np.int64), np.empty((n, 8))
    count = tied.find_ties(node_block(w_block), np.array([2, 0, 0]), np.array([4, 6, 6]), 2,
                           node_block(c_block), occupied.ravel(), TieSet(*out, 0))
    assert count == 7 * 7                            # the x = 1 face only
    assert np.all(out[0][:count] // w_block.strides[0] == 0)


def test_split_lays_children_out_by_the_stretch_and_divides_mass():
    """Eq. 25: a particle stretched by F = diag(1.2, 0.9, 1) splits into R^3 children at
    the centres of its deformed sub-cubes; mass, volume and load share are divided,
    stress and history copied; ids come from the parent's."""
    p = Particles.empty(2)
    p.x[:] = [[1.0, 1.0, 1.0], [5.0, 5.0, 5.0]]
    p.mass[:], p.vol0[:], p.rho[:] = 8e-3, 1.0, 8e-3
    p.F[:] = np.diag([1.2, 0.9, 1.0]).ravel()
    p.stress[:] = [1, 2, 3, 4, 5, 6]
    p.eps_p[:], p.e_int[:], p.load_scale[:] = 0.3, 7.0, 1.0
    p.id[:] = [10, 11]
    p.refine[:] = 1
    added = split(p, [0], [2], id_base=100, id_stride=8)
    assert p.n == 2 and sorted(added) == sorted(p.COLUMNS) and len(added["mass"]) == 7
    p.append(added)
    kids = p.id >= 100
    assert sorted(p.id[kids]) == list(range(100 + 10 * 8, 100 + 10 * 8 + 8))
    assert p.mass[kids].sum() == pytest.approx(8e-3) and np.all(p.refine[kids] == 2)
    assert np.allclose(p.vol0[kids], 1 / 8) and np.allclose(p.load_scale[kids], 1 / 8)
    assert np.all(p.stress[kids] == [1, 2, 3, 4, 5, 6]) and np.all(p.e_int[kids] == 7.0)
    assert np.all(p.eps_p[kids] == 0.3)
    expected = 1.0 + sub_cube_offsets(2) * [1.2, 0.9, 1.0]
    assert np.allclose(np.sort(p.x[kids], axis=0), np.sort(expected, axis=0))
    assert p.x[~kids].tolist() == [[5.0, 5.0, 5.0]]


def test_window_moves_in_whole_cells_and_carries_the_rest():
    w = Window([2, 2, 2], [4, 4, 4], 2)
    assert not w.move(np.array([0.6, 0.0, 0.0]), 1.0, [10, 10, 10])
    assert w.move(np.array([0.6, 0.0, -1.3]), 1.0, [10, 10, 10])
    assert w.lo.tolist() == [3, 2, 1] and w.hi.tolist() == [5, 4, 3]
    assert w.residual == pytest.approx([0.2, 0.0, -0.3])
    w.move(np.array([20.0, 0.0, 0.0]), 1.0, [10, 10, 10])       # stops at the box face
    assert w.hi.tolist()[0] == 10 and w.residual[0] == 0.0
    assert w.move(np.array([-1.0, 0.0, 0.0]), 1.0, [10, 10, 10])  # and comes back at once
    assert w.hi.tolist()[0] == 9


# ---------------------------------------------------------------- runs

def wave_sets(cell, ratio, width=None):
    return [f"params.cell={cell}", f"params.ratio={ratio}",
            f"params.width={width or cell}"]


def test_a_window_of_ratio_1_is_the_uniform_grid(tmp_path):
    """R = 1: TIGMPM is MPM (Sec. 5.1); such a window is left out, so that it changes
    nothing (not even contact across its faces)."""
    short = ["time.end=0.0156", "output.times=[0.0156]"]
    run_pmpm(WAVE, tmp_path / "tied", sets=wave_sets(1.0, 1) + short)
    run_pmpm(WAVE, tmp_path / "plain", sets=wave_sets(1.0, 1) + short + ["grid.windows=[]"])
    a, b = read_frame(tmp_path / "tied"), read_frame(tmp_path / "plain")
    ia, ib = np.argsort(a["id"]), np.argsort(b["id"])
    assert np.abs(a["x"][ia] - b["x"][ib]).max() < 1e-12 * 100
    assert np.abs(a["stress"][ia] - b["stress"][ib]).max() < 1e-9 * 2.5 / 36


C, LOAD = np.sqrt(1.0e5 / 5.0e-3), -2.5 / 36.0


def wave_errors(out):
    prof = axial_profiles(out, (0.0076, 0.0156, 0.0416), volumes=True)
    return [rms_error(s, wave_bar_stress(x, t, 100.0, C, LOAD), LOAD, w)
            for t, (x, s, w) in sorted(prof.items())]


@pytest.fixture(scope="module")
def wave_runs(tmp_path_factory):
    """Uniform 0.5 and 1 mm, and TIGMPM R = 2 (0.5 mm window over the loaded 40 mm,
    1 mm outside), one cell wide (slip faces: 1D)."""
    outs = {}
    for name, (cell, ratio) in {"fine": (0.5, 1), "coarse": (1.0, 1), "tied": (1.0, 2)}.items():
        outs[name] = tmp_path_factory.mktemp(f"wave_{name}")
        run_pmpm(WAVE, outs[name], sets=wave_sets(cell, ratio, 1.0))
    return {name: wave_errors(out) for name, out in outs.items()}


def test_tied_wave_equals_the_fine_grid_before_the_interface(wave_runs):
    """Seed 000 Fig. 9: at 7.6 us the front (at 66 mm) has not reached the interface at
    60 mm, so TIGMPM equals MPM on its refined cell."""
    assert wave_runs["tied"][0] == pytest.approx(wave_runs["fine"][0], rel=1e-3)
    assert wave_runs["tied"][0] < 0.9 * wave_runs["coarse"][0]


def test_tied_wave_lies_between_fine_and_coarse_after_the_interface(wave_runs):
    """Seed 000 Fig. 10 and Table 1: at 15.6 us the error of TIGMPM lies between those
    of MPM on the fine and on the coarse grid; at 41.6 us it is near the coarse one."""
    fine, tied_, coarse = (wave_runs[k][1] for k in ("fine", "tied", "coarse"))
    assert fine < tied_ < coarse
    assert wave_runs["tied"][2] == pytest.approx(wave_runs["coarse"][2], rel=0.1)



#: relative momentum drift: hats 1.7e-15 (round-off). The 27-node shapes reach coarse
#: nodes inside the window, tied to the window nodes; when a coarse particle at the edge
#: of its support gives such a node a mass below the empty-node cut-off (1e-12 of the
#: mean particle mass) and nothing else is there, its small force is dropped, as at any
#: nearly empty node: measured 1.2e-11 (gimp) and 3e-12 (bspline), 1.7e-15 with the
#: cut-off at 1e-30
MOMENTUM_DRIFT = {"linear": 1e-13, "gimp": 5e-11, "bspline": 5e-11}

@pytest.mark.parametrize("shape", ["linear", "gimp", "bspline"])
def test_mass_and_momentum_are_conserved_through_the_tied_interface(tmp_path, shape):
    """No boundary acts (free faces, no gravity): a spinning, expanding elastic block
    across a window face keeps its mass and momentum to round-off while its particles
    move through the tied interface and split (27-node shapes: window particles also
    reach the tied window nodes beyond the face)."""
    sets = [f"grid.shape_functions={shape}", "grid.windows=[{min: [6, 0, 0], max: [12, 8, 8], ratio: 2}]",
            "bodies.0.geometry={type: box, min: [3, 3, 3], max: [7, 5, 5]}",
            "bodies.0.velocity=[150, 20, -30]",
            "bodies.1.geometry={type: box, min: [8, 3, 3], max: [10, 5, 5]}",
            "bodies.1.velocity=[-150, 0, 40]", "params.method=0", "time.end=0.02"]
    out = tmp_path / "out"
    run_pmpm(FOLLOW, out, sets=sets)
    first, last = (read_frame(out, i) for i in (0, -1))
    summary = read_summary(out)
    assert summary["n_particles"]["final"] > summary["n_particles"]["initial"]   # split
    assert last["mass"].sum() == pytest.approx(first["mass"].sum(), rel=1e-13)
    p0 = first["mass"] @ first["v"]
    p1 = last["mass"] @ last["v"]
    scale = np.abs(first["mass"] @ np.abs(first["v"])).max()
    assert np.abs(p1 - p0).max() < MOMENTUM_DRIFT[shape] * scale
    assert np.abs(last["v"] - last["v"].mean(axis=0)).max() > 10.0      # it did deform


def test_window_follows_the_cube_and_splits_the_plate(tmp_path):
    out = tmp_path / "out"
    run_pmpm(FOLLOW, out)
    summary = read_summary(out)
    frame = read_frame(out)
    plate = frame["body"] == 1
    fine = np.isclose(frame["mass"], 7.85e-3 / 64)
    assert summary["bodies"]["cube"]["velocity"][0] == pytest.approx(200.0, rel=1e-12)
    # the window went from x in [1, 6) to [7, 12) with the cube (6 mm in 30 us): every
    # plate particle in x < 12, z >= 1 it passed over has been split
    swept = plate & (frame["x"][:, 0] < 12) & (frame["x"][:, 2] > 1) \
        & (frame["x"][:, 1] > 2) & (frame["x"][:, 1] < 6)
    assert swept.sum() > 0 and np.all(fine[swept])
    assert np.all(~fine[plate & (frame["x"][:, 2] < 1)])
    assert summary["n_particles"]["final"] - summary["n_particles"]["initial"] == 7 * 192
    assert len(np.unique(frame["id"])) == len(frame["id"])


@pytest.mark.parametrize("sets", [[], ["params.method=0"]], ids=["contact", "no_contact"])
def test_moving_window_with_splitting_on_two_ranks_gives_the_one_rank_answer(tmp_path, sets):
    run_pmpm(FOLLOW, tmp_path / "one", sets=sets)
    run_pmpm(FOLLOW, tmp_path / "two", ranks=2, sets=sets)
    a, b = read_frame(tmp_path / "one"), read_frame(tmp_path / "two")
    ia, ib = np.argsort(a["id"]), np.argsort(b["id"])
    assert np.array_equal(a["id"][ia], b["id"][ib])
    assert np.abs(a["x"][ia] - b["x"][ib]).max() < 1e-10 * 24
    assert np.abs(a["v"][ia] - b["v"][ib]).max() < 1e-10 * 200
    assert read_summary(tmp_path / "two")["slabs"]["bounds"][1] not in (0, 24)


def test_tied_wave_on_two_ranks_gives_the_one_rank_answer(tmp_path):
    """The window and its tied interface cut by the slab plane (the x axis)."""
    sets = wave_sets(1.0, 2, 1.0) + ["time.end=0.0156", "output.times=[0.0156]",
                                     "decomposition.axis=x"]
    run_pmpm(WAVE, tmp_path / "one", sets=sets)
    run_pmpm(WAVE, tmp_path / "two", ranks=2, sets=sets)
    a, b = read_frame(tmp_path / "one"), read_frame(tmp_path / "two")
    ia, ib = np.argsort(a["id"]), np.argsort(b["id"])
    assert np.abs(a["x"][ia] - b["x"][ib]).max() < 1e-10 * 100
    assert np.abs(a["stress"][ia] - b["stress"][ib]).max() < 1e-8 * abs(LOAD)


def test_readme_window_example_validates():
    import pathlib
    import re
    text = (pathlib.Path(__file__).resolve().parent.parent / "README.md").read_text()
    block = re.search(r"```yaml\n(.*?)```", text.split("#### `grid.windows`", 1)[1], re.S)
    import yaml
    grid = yaml.safe_load(block.group(1))["grid"]
    raw = case_with_window()
    raw["grid"] = grid
    raw["bodies"][0]["geometry"]["max"] = [100, 6, 6]
    case = validate_case(raw)
    assert case["grid"]["windows"] == [{"min": [60.0, 0.0, 0.0], "max": [100.0, 6.0, 6.0],
                                        "ratio": 4}]


def test_restart_of_a_moving_window_run_ends_where_the_uninterrupted_one_does(tmp_path):
    """The window's position, its carried-over residual and the followed centroid travel
    in the checkpoint; split particles' ids come from the same base."""
    run_pmpm(FOLLOW, tmp_path / "full")
    cut = tmp_path / "cut"
    run_pmpm(FOLLOW, cut, sets=["time.end=0.01"])            # a frame time of the full run
    done = run_pmpm(FOLLOW, cut, sets=["time.end=0.03"], extra=["--restart"])
    assert done.returncode == 0
    a, b = read_frame(tmp_path / "full"), read_frame(cut)
    assert np.array_equal(a["id"], b["id"])
    assert np.abs(a["x"] - b["x"]).max() < 1e-12 * 24
    assert read_summary(cut)["windows"] == read_summary(tmp_path / "full")["windows"]
