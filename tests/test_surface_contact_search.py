"""Particle-to-surface contact (ICFEMP) search (issue 24 Sec. 4): a centre found behind
a face is corrected whether or not it approaches, a centre that crossed a face faster
than its contact window is wide is still found (the search reaches its radius plus what
it and the face moved in the step), a centre is not pulled through a thin body to the
wrong side, and the deepest centre of the run is in summary.json.
Case: tests/cases/fast_layer_thin_plate.yaml (one layer of 64 particles, radius 5 mm,
over a free plate one element (20 mm) thick)."""
import os

import numpy as np

from pmpm.kernels import surface_contact as ksc
from test_surface_contact import momentum, run

HERE = os.path.dirname(os.path.abspath(__file__))
CASE = os.path.join(HERE, "cases", "fast_layer_thin_plate.yaml")
RADIUS = 0.005


def simulation(overrides=(), world=None):
    from runhelp import set_up
    return set_up(CASE, overrides, world)


def layer_gaps(sim):
    """Height of every layer centre above the plate's top face (its highest nodes)
    and below its bottom face: (above top, above bottom)."""
    p, x = sim.particles, sim.elements.x
    z = p.x[p.body == 1, 2]
    return z - x[:, 2].max(), z - x[:, 2].min()


def test_a_layer_faster_than_its_window_stays_on_its_side_of_a_thin_plate():
    """20 m/s at cfl 0.9: the layer, 1 mm outside its window (centres 6 mm above the
    face), moves 14.3 mm in the first step and ends it 9.3 mm behind the top face, deeper
    than its radius (before issue 24 Sec. 4 it was never found and flew through the
    plate). Found, it is stopped and put back on the face: every centre stays above the
    top face at every step end, momentum (layer + plate) is kept to round-off and the
    energy only falls (the stop is inelastic)."""
    sim = simulation()
    start, energy = momentum(sim), sim.energies()["total"]
    above, energies = [], []

    def watch(s):
        above.append(layer_gaps(s)[0].min())
        energies.append(s.energies()["total"])
    run(sim, 0.005, cfl=0.9, every=watch)
    assert sim.surface.deepest > RADIUS * 1.5        # it did go deeper than its window
    assert min(above) > 0.0
    assert np.abs(momentum(sim) - start).max() < 1e-12 * np.abs(start).max()
    assert max(energies) <= energy * (1 + 1e-12)
    vz = sim.particles.v[sim.particles.body == 1, 2]
    assert vz.min() > -1.0                             # stopped (the plate: -0.16 m/s)


def test_a_layer_at_rest_inside_a_face_is_pushed_out_without_gaining_energy():
    """Centres moved 2 mm inside the top face (within their 5 mm radius), sliding along
    it at 1 m/s, not approaching: each step moves them out by half their depth (the
    position only), so the depth falls below 1e-6 of the radius within 25 steps, and the
    total energy never rises above its start (before issue 24 Sec. 4 a pair that did not
    approach was not corrected: the centres stayed inside)."""
    sim = simulation(["params.v=0.0", "bodies[1].velocity=[1.0, 0, 0]"])
    layer = sim.particles.body == 1
    sim.particles.x[layer, 2] -= 0.007         # from 5 mm above the face to 2 mm inside
    energy = sim.energies()["total"]
    depth, energies = [-layer_gaps(sim)[0].min()], []
    assert abs(depth[0] - 0.002) < 1e-12

    def watch(s):
        depth.append(-layer_gaps(s)[0].min())
        energies.append(s.energies()["total"])
    run(sim, 0.025, cfl=0.9, every=watch)
    assert len(depth) > 25 and depth[25] < 1e-6 * RADIUS
    assert max(energies) <= energy * (1 + 1e-12)
    assert abs(sim.surface.deepest - max(depth[:-1])) < 1e-12 * RADIUS   # trial positions


def test_a_centre_that_crossed_a_thin_plate_from_below_keeps_to_the_bottom_face():
    """One hexahedron 20 mm thick seen as two faces, top (+z) and bottom (-z). A centre
    that moved up from 2 mm below the bottom face to 14 mm above it (6 mm behind the top
    face, 14 mm behind the bottom) is paired with the bottom face it came through, not
    pulled out through the top; the same trial centre coming from above pairs with the
    top face; one that was deeper than its radius behind both faces at the start is left
    alone."""
    square = np.array([[0, 0], [0.04, 0], [0.04, 0.04], [0, 0.04]], float)
    top = np.column_stack([square, np.full(4, 0.02)])
    bottom = np.column_stack([square[::-1], np.zeros(4)])     # counter-clockwise from below
    faces = np.ascontiguousarray(np.stack([top, bottom]))
    start, items = np.array([0, 2], np.int64), np.array([0, 1], np.int64)
    now = np.array([[0.02, 0.02, 0.014]])
    found = {}
    for name, z0 in (("below", -0.002), ("above", 0.024), ("inside", 0.01)):
        seg, geo = np.empty(1, np.int64), np.empty((1, 6))
        moved = abs(0.014 - z0)
        ksc.find_pairs(now, np.array([[0.02, 0.02, z0]]), np.zeros(1, np.int64),
                       np.full(1, (2 * RADIUS) ** 3), np.full(1, moved), faces, faces,
                       np.zeros(2), np.ones(2, np.int64), np.arange(2, dtype=np.int64),
                       np.array([[False, True], [False, False]]), np.full(3, -1.0), 0.1,
                       np.ones(3, np.int64), start, items, seg, geo)
        found[name] = (seg[0], geo[0])
    assert found["below"][0] == 1 and np.allclose(found["below"][1][2:5], [0, 0, -1])
    assert abs(found["below"][1][5] + 0.014) < 1e-12
    assert found["above"][0] == 0 and abs(found["above"][1][5] + 0.006) < 1e-12
    assert found["inside"][0] == -1


def test_summary_json_carries_the_deepest_centre(tmp_path):
    """The command line's summary.json has surface_contact.largest_penetration, the
    deepest centre of the run (the 9.3 mm of the fast layer), as the solver measured
    it."""
    from clihelp import run_ok
    from pmpm.io.summary import read_summary
    run_ok([CASE, "--out", tmp_path / "run", "--quiet"])
    summary = read_summary(tmp_path / "run")
    sim = simulation()
    run(sim, 0.005, cfl=0.9)
    deepest = summary["surface_contact"]["largest_penetration"]
    assert abs(deepest - sim.surface.deepest) < 1e-12 and 0.009 < deepest < 0.0095


def test_a_restart_keeps_the_deepest_centre(tmp_path):
    """Stopped at 2 ms (after the 9.3 mm of the first step) and continued from the
    checkpoint to 5 ms: the summary's deepest centre is the uninterrupted run's (the
    checkpoint keeps it)."""
    from clihelp import run_ok
    from pmpm.io.summary import read_summary
    whole, split = tmp_path / "whole", tmp_path / "split"
    run_ok([CASE, "--out", whole, "--quiet"])
    run_ok([CASE, "--out", split, "--quiet", "--set", "time.end=0.002"])
    run_ok([CASE, "--out", split, "--quiet", "--restart"])
    deepest = [read_summary(out)["surface_contact"]["largest_penetration"]
               for out in (whole, split)]
    assert deepest[0] == deepest[1] > 0.009
