"""Taylor bar, seed 000 Sec. 5.2, coarse (0.76 mm cells, 21,172 particles): final length
and foot diameter against Table 3's MPM row, energy conservation, 1 rank == 2 ranks.

L and D are measured from particle centres. Seed 000 does not say how D was measured.
pmpm gives L = 16.24 mm (Table 3: 16.39, -0.9 %); the footprint's equivalent-circle
diameter (pmpm.post.foot_diameter) is D = 12.78 mm (Table 3: 12.68, +0.8 %; the
experiment: 13.5), the widest centre 13.00 mm (+2.5 %): on this coarse grid the foot
spreads 8 % further along the grid axes than between them. At 0.38 mm: L = 16.25
(16.29), D = 13.20 (13.14, +0.5 %; widest 13.26): scripts/taylor_bar.py.
"""
import os

import numpy as np
import pytest

from pmpm.post import (convex_hull_area, foot_diameter, read_frame, read_summary,
                       taylor_length_and_diameter)
from runhelp import RUNS, run_pmpm

CASE = os.path.join(RUNS, "taylor_bar.yaml")
PAPER_L, PAPER_D = 16.39, 12.68          # seed 000 Table 3, MPM, cell 0.76 mm


@pytest.fixture(scope="module")
def one_rank(tmp_path_factory):
    out = tmp_path_factory.mktemp("taylor1")
    run_pmpm(CASE, out)
    return out


def test_particle_count_matches_table_4(one_rank):
    assert read_summary(one_rank)["n_particles"]["initial"] == 21172


def test_final_length_and_foot_diameter_match_table_3(one_rank):
    frame = read_frame(one_rank)
    assert frame["time"] == pytest.approx(0.08)
    length, widest = taylor_length_and_diameter(frame["x"])
    assert length == pytest.approx(PAPER_L, rel=0.02)
    assert foot_diameter(frame["x"]) == pytest.approx(PAPER_D, rel=0.02)
    assert widest == pytest.approx(PAPER_D, rel=0.03)


def test_foot_diameter_is_the_footprints_equivalent_circle():
    square = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [1, 1], [0.5, 1.5]], float)
    assert convex_hull_area(square) == pytest.approx(4.0)
    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    ring = np.c_[3 * np.cos(t), 3 * np.sin(t), np.zeros_like(t)]
    assert foot_diameter(np.r_[ring, 0.5 * ring]) == pytest.approx(6.0, rel=1e-5)


def test_energy_is_conserved(one_rank):
    hist = np.genfromtxt(os.path.join(one_rank, "history.csv"), delimiter=",", names=True)
    total = hist["total"]
    assert abs(total[-1] - total[0]) / total[0] < 0.01
    assert hist["kinetic"][-1] < 0.05 * hist["kinetic"][0]          # the bar has stopped


def test_two_ranks_give_the_one_rank_answer(one_rank, tmp_path):
    """The 2-rank run stops at the one-rank run's second frame, 0.02 ms: a quarter of the
    run's steps (256 of 1012), by when the foot has spread to 11.9 of its final 12.8 mm
    and the bar shortened from 25.4 to 21.6 mm. With frames at 0.01 and 0.02 it takes the
    same steps up to there as the full run (8 frames, 0.01 apart), so the two agree to
    round-off."""
    run_pmpm(CASE, tmp_path, ranks=2, sets=["time.end=0.02", "output.frames=2"])
    a, b = read_frame(one_rank, 2), read_frame(tmp_path)
    assert a["time"] == b["time"] == 0.02
    assert np.array_equal(a["id"], b["id"])
    assert np.abs(a["x"] - b["x"]).max() / PAPER_L < 1e-10
    assert read_summary(tmp_path)["ranks"] == 2


# ------------------------------------------------------------ the default shape functions

def test_27_node_shapes_spread_the_foot_as_the_hats_do(one_rank, tmp_path):
    """Issue 23: with the halo nodes beyond the wall merely held at zero normal velocity,
    gimp and bspline gave the particles next to the wall half their compression rate, and
    the foot came out 12 % narrower than the hats' (11.24 and 11.51 mm against 12.78).
    With the halo reflected (pmpm.kernels.boundary.mirror_rows) both are within 3 % of
    the hats: gimp L 16.13, D 12.86; bspline 16.08, 12.94 (the hats 16.24, 12.78). The
    default, gimp, is held to the experiment by tests/test_matrix.py; this checks the
    other 27-node shape against the hats."""
    run_pmpm(CASE, tmp_path, ranks=2, sets=["grid.shape_functions=bspline"])
    hats = read_frame(one_rank)["x"]
    x = read_frame(tmp_path)["x"]
    hats_length, _ = taylor_length_and_diameter(hats)
    length, _ = taylor_length_and_diameter(x)
    assert length == pytest.approx(hats_length, rel=0.03)
    assert foot_diameter(x) == pytest.approx(foot_diameter(hats), rel=0.03)
    assert abs(read_summary(tmp_path)["energy_balance"]["growth"]) < 0.01


# ---------------------------------------------------------------- tied interface grid

# Seed 000 Table 3, TIGMPM: R = 2 (0.19 mm window, 0.38 outside): L = 16.29, D = 13.28;
# R = 4 (0.19 / 0.76): 16.29, 13.24. The coarse test refines the bottom 3.8 mm at
# 0.38 mm with 0.76 mm cells outside (R = 2, one level coarser than the paper's case I).
TIED_SETS = ["params.ratio=2", "params.refined=3.8"]
TIED_L, TIED_D = 16.29, 13.28


@pytest.mark.parametrize("cell, ratio, count", [(0.38, 2, 696416), (0.76, 4, 614572)])
def test_tied_grid_particle_counts_match_table_4(cell, ratio, count):
    """Table 4's counts are those of a window over the bottom 11.4 mm (the case default)."""
    from pmpm.case import fill_body, load_case
    case = load_case(CASE, [f"params.cell={cell}", f"params.ratio={ratio}"])
    assert len(fill_body(case["bodies"][0], case["grid"])[0]) == count


@pytest.fixture(scope="module")
def tied_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("taylor_tied")
    run_pmpm(CASE, out, sets=TIED_SETS)
    return out


def test_tied_grid_foot_takes_the_refined_diameter(tied_run, one_rank):
    """D is set by the refined window (seed 000 Sec. 5.2): wider than on the uniform
    0.76 mm grid, near Table 3's TIGMPM value; L near it too; energy conserved."""
    x = read_frame(tied_run)["x"]
    length, diameter = taylor_length_and_diameter(x)
    _, coarse_diameter = taylor_length_and_diameter(read_frame(one_rank)["x"])
    assert diameter > 1.01 * coarse_diameter
    assert diameter == pytest.approx(TIED_D, rel=0.02)
    assert foot_diameter(x) == pytest.approx(TIED_D, rel=0.02)
    assert length == pytest.approx(TIED_L, rel=0.02)
    hist = np.genfromtxt(os.path.join(tied_run, "history.csv"), delimiter=",", names=True)
    assert abs(hist["total"][-1] - hist["total"][0]) / hist["total"][0] < 0.01


def test_coarse_particles_that_reach_the_window_are_split(tied_run):
    summary = read_summary(tied_run)
    n = summary["n_particles"]
    assert n["initial"] == 43292
    assert (n["final"] - n["initial"]) % 7 == 0 and n["final"] > 1.3 * n["initial"]
    frame = read_frame(tied_run)
    in_window = frame["x"][:, 2] < 3.8
    assert np.allclose(frame["mass"][in_window], 8.93e-3 * 0.19 ** 3)
    first = read_frame(tied_run, 0)
    assert summary["bodies"]["bar"]["mass"] == pytest.approx(first["mass"].sum(), rel=1e-12)


def test_tied_grid_on_two_ranks_gives_the_one_rank_answer(tmp_path):
    sets = TIED_SETS + ["time.end=0.01", "decomposition.axis=z"]
    run_pmpm(CASE, tmp_path / "one", sets=sets)
    run_pmpm(CASE, tmp_path / "two", ranks=2, sets=sets)
    a, b = read_frame(tmp_path / "one"), read_frame(tmp_path / "two")
    assert np.array_equal(a["id"], b["id"])
    assert np.abs(a["x"] - b["x"]).max() / PAPER_L < 1e-10
