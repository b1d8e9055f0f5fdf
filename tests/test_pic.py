"""The FLIP/PIC blend (time.pic): off by default; a share of the grid's velocity in the
particle velocity update damps the noise of particles crossing cells."""
import csv

import numpy as np
import pytest

from clihelp import pmpm
from pmpm.grid import LocalBlock
from pmpm.kernels import mpm
from pmpm.kernels.records import GridGeometry, PointState
from runhelp import RUNS


def test_pic_one_gives_the_grid_velocity_and_zero_the_flip_update():
    rng = np.random.default_rng(3)
    n = 50
    b = LocalBlock(np.zeros(3, np.int64), np.full(3, 5), 0, [])
    gnew = rng.normal(size=(b.n_nodes, 6))
    geo = GridGeometry(np.zeros(3), 1.0, b.lo, b.strides, (), np.zeros(1))
    x0, v0 = rng.uniform(0.2, 3.8, (n, 3)), rng.normal(size=(n, 3))
    results = {}
    for pic in (0.0, 1.0, 0.25):
        pts = PointState(x0.copy(), v0.copy(), np.ones(n), np.zeros(n, np.int32),
                         np.zeros(n, np.int32))
        mpm.grid_to_particles(pts, np.zeros(1, np.bool_), 1e-3, geo, gnew, None, 0, pic)
        results[pic] = pts
    grid_velocity = (results[1.0].x - x0) / 1e-3           # sum_I N_I v_I at the particle
    assert results[1.0].v == pytest.approx(grid_velocity, rel=1e-9, abs=1e-9)
    blend = 0.75 * results[0.0].v + 0.25 * grid_velocity
    assert results[0.25].v == pytest.approx(blend, rel=1e-12, abs=1e-12)
    assert np.array_equal(results[0.0].x, results[1.0].x)  # positions do not depend on it


def total_energy(out):
    with open(out / "history.csv", encoding="utf-8") as handle:
        return np.array([float(row["total"]) for row in csv.DictReader(handle)])


def test_a_pic_share_damps_the_vibrating_bar(tmp_path):
    sets = ["--set", "params.periods=1.5", "--set", "output.energy_warning=0",
            "--set", "grid.shape_functions=linear"]           # the hats, which gain here
    for name, extra in (("flip", []), ("pic", ["--set", "time.pic=0.05"])):
        assert pmpm([f"{RUNS}/vibrating_bar.yaml", "--out", tmp_path / name, "--quiet",
                     *sets, *extra], timeout=300).returncode == 0
    flip, pic = total_energy(tmp_path / "flip"), total_energy(tmp_path / "pic")
    assert pic[-1] < pic[0] < flip[-1]                      # damped, where FLIP gains
