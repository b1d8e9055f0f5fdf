"""Probes (output.probes, issue 26): particles followed through the run, their history
in probe_NAME.csv; the same on 1 and 2 ranks and through a restart."""
import csv
import os

import numpy as np
import pytest

from clihelp import BAR, BAR_HALF_END, pmpm, run_ok
from pmpm.io.derived import stress_invariants
from pmpm.post import read_frame

PROBES = "output.probes=[{name: tip, body: bar, point: [0, 0, 0]}, " \
         "{name: top, body: bar, point: [1, 0, 6]}, {name: tagged, body: bar, id: 100}, " \
         "{name: foot, body: bar, region: {min: [-4, -4, 0], max: [4, 4, 1.5]}}]"
#: the bar's particles lie on a 0.5 mm lattice from 0.25: z = 1.5 falls between layers
FOOT = (np.array([-4.0, -4.0, 0.0]), np.array([4.0, 4.0, 1.5]))


def read_probe(out, name):
    with open(os.path.join(out, f"probe_{name}.csv"), newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


def nearest_id(frame, point):
    d2 = ((frame["x"] - np.asarray(point)) ** 2).sum(axis=1)
    return frame["id"][np.lexsort((frame["id"], d2))[0]]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    base = tmp_path_factory.mktemp("probes")
    outs = {ranks: base / f"r{ranks}" for ranks in (1, 2)}
    for ranks, out in outs.items():
        run_ok([BAR, "--out", out, "--quiet", "--set", PROBES], ranks)
    return outs


def test_a_probe_follows_the_particle_nearest_its_point(runs):
    out = runs[1]
    first, last = read_frame(out, 0), read_frame(out, -1)
    for name, point in (("tip", (0, 0, 0)), ("top", (1, 0, 6))):
        header, rows = read_probe(out, name)
        assert header[:8] == ["step", "time", "x", "y", "z", "vx", "vy", "vz"]
        assert header[-3:] == ["eps_p", "pressure", "von_mises"]
        k = int(np.flatnonzero(last["id"] == nearest_id(first, point))[0])
        assert rows[-1, 1] == last["time"]
        assert np.array_equal(rows[-1, 2:5], last["x"][k])
        assert np.array_equal(rows[-1, 5:8], last["v"][k])
        assert np.array_equal(rows[-1, 8:14], last["stress"][k])
        pressure, von_mises = stress_invariants(last["stress"][k:k + 1])
        assert rows[-1, 15] == pressure[0] and rows[-1, 16] == von_mises[0]
        assert rows[0, 0] == 0 and rows[-1, 0] == 48
    tip = read_probe(out, "tip")[1]
    assert tip[-1, 14] > 0.0              # the impact face has yielded


def test_a_probe_by_id_follows_that_particle(runs):
    last = read_frame(runs[1], -1)
    k = int(np.flatnonzero(last["id"] == 100)[0])
    rows = read_probe(runs[1], "tagged")[1]
    assert np.array_equal(rows[-1, 2:14], np.concatenate([last["x"][k], last["v"][k],
                                                          last["stress"][k]]))


def test_a_region_probe_holds_the_mass_weighted_means_of_its_tagged_particles(runs):
    """The bar's foot: the particles within 1.5 mm of the wall at the start, however they
    spread, averaged by mass (von Mises: the mean of theirs), as the final frame gives."""
    last = read_frame(runs[1], -1)
    start = last["x"] - last["displacement"]
    inside = np.all((start >= FOOT[0]) & (start <= FOOT[1]), axis=1)
    assert inside.sum() == 3 * 52                  # three layers of 52 particles
    m = last["mass"][inside]
    pressure, von_mises = stress_invariants(last["stress"][inside])
    columns = np.hstack([last["x"][inside], last["v"][inside], last["stress"][inside],
                         last["eps_p"][inside][:, None], pressure[:, None],
                         von_mises[:, None]])
    rows = read_probe(runs[1], "foot")[1]
    assert np.allclose(rows[-1, 2:], m @ columns / m.sum(), rtol=1e-12, atol=1e-9)
    assert rows[-1, 14] > 0.0 and rows[0, 7] == pytest.approx(-100.0)


@pytest.mark.parametrize("probe, message", [
    ("{name: p, body: bar, id: 99999}", "output.probes[0].id: is no id of a particle of "
                                        "body 'bar'"),
    ("{name: p, body: bar, region: {min: [5, 5, 5], max: [6, 6, 6]}}",
     "output.probes[0].region: selects no particle of body 'bar'"),
    ("{name: p, body: bar, id: 3, point: [0, 0, 0]}",
     "output.probes[0]: give exactly one of point, id and region"),
    ("{name: p, body: bar, id: 3, fixed: true}", "output.probes[0].fixed: a fixed gauge")])
def test_a_probe_that_samples_nothing_or_two_things_is_refused(tmp_path, probe, message):
    done = pmpm([BAR, "--out", tmp_path, "--quiet", "--set", f"output.probes=[{probe}]"])
    assert done.returncode == 2 and message in done.stderr, done.stderr


def test_two_ranks_give_the_one_rank_probes(runs):
    for name in ("tip", "top", "tagged", "foot"):
        one, two = read_probe(runs[1], name)[1], read_probe(runs[2], name)[1]
        assert one.shape == two.shape
        assert np.allclose(one, two, rtol=1e-10, atol=1e-9)


def test_a_restart_continues_the_probe_files(tmp_path, runs):
    out = tmp_path / "cut"
    run_ok([BAR, "--out", out, "--quiet", "--set", PROBES,
            "--set", f"time.end={BAR_HALF_END}"])
    run_ok([BAR, "--out", out, "--quiet", "--restart", "--set", PROBES])
    for name in ("tip", "top"):
        assert np.array_equal(read_probe(out, name)[1], read_probe(runs[1], name)[1])


def test_a_fixed_probe_samples_the_particle_nearest_its_point_now(tmp_path):
    """``fixed: true``: a gauge at a place; at the last row it reads the particle nearest
    the point in the final frame, a different one from the followed probe's."""
    fixed = "output.probes=[{name: gauge, body: bar, point: [0, 0, 0.3], fixed: true}, " \
            "{name: tip, body: bar, point: [0, 0, 0.3]}]"
    run_ok([BAR, "--out", tmp_path, "--quiet", "--set", fixed])
    last = read_frame(tmp_path, -1)
    k = int(np.flatnonzero(last["id"] == nearest_id(last, (0, 0, 0.3)))[0])
    gauge, tip = read_probe(tmp_path, "gauge")[1], read_probe(tmp_path, "tip")[1]
    assert np.array_equal(gauge[-1, 2:5], last["x"][k])
    assert np.array_equal(gauge[-1, 8:14], last["stress"][k])
    assert np.array_equal(gauge[0], tip[0])          # the same particle at the start
    assert gauge[-1, 4] <= tip[-1, 4] + 1e-12    # never farther than the followed one


def test_a_probe_on_an_fem_body_follows_a_node(tmp_path):
    """The struck FEM bar's far end: the node there, its velocity once the pulse has
    arrived, NaN stresses; the same on 2 ranks as on 1."""
    case = os.path.join(os.path.dirname(BAR), "striker_on_fem_bar.yaml")
    probe = "output.probes=[{name: end, body: bar, point: [52, 0, 0]}]"
    found = {}
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        run_ok([case, "--out", out, "--quiet", "--set", probe, "--set", "time.end=0.015",
                "--set", "output.history_every=5"], ranks)
        found[ranks] = read_probe(out, "end")[1]
    rows = found[1]
    assert np.array_equal(rows[0, 2:5], [52.0, 0.0, 0.0])
    assert np.all(np.isnan(rows[:, 8:]))
    assert rows[0, 5] == 0.0 and rows[:, 5].max() > 8.0   # the free end flies at about v0
    assert np.allclose(found[2], rows, equal_nan=True, rtol=1e-9, atol=1e-12)
