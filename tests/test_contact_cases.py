"""Coarse runs of the contact validation cases of issue 3 (seed 001 Sec. 5): two elastic
rings (5.1), a sphere rolling down an incline (5.2), a steel ball perforating a thin
plate (5.3) and an ogive rod perforating a thick plate at 30 degrees (5.4).

Tests marked ``needs_contact`` check physics that only multi-velocity contact (methods 1
and 2) gives: rings that bounce apart, a sphere that rolls, plates that are perforated.
Standard MPM (method 0, one shared velocity field) glues touching bodies together, which
the unmarked tests check. ``pytest -m "not needs_contact"`` leaves the former out.

The runs are coarser or smaller than the full ones of scripts/ (which hold the paper's
tolerances), each case's runs two at a time:

- rings: full resolution (2 mm cells, 4,392 particles per ring), cfl 0.5, 5 ms;
- sphere: 0.4 m cells instead of 0.2 (10,176 particles), the full 2 s;
- steel ball: the paper's 0.66 mm cells, but a square plate 40 x 40 mm clamped at its
  edges instead of a free disc 178 mm across (14,456 particles), 180 us;
- ogive rod: 2 mm cells, a 60 x 60 mm plate instead of 110 x 110, 1 mm rod spacing
  (51,746 particles), 575 m/s, 0.2 ms.
"""
import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from pmpm.case import fill_body, load_case
from pmpm.post import (body_index, body_points, count_pieces, energy_steps, free_after,
                       min_distance, perforation, read_frame, read_history, read_summary,
                       residual_velocity, rolling_sphere_travel, travel, until_separation)
from runhelp import RUNS, run_pmpm

needs_contact = pytest.mark.needs_contact
# The rings run with the MUSL update order (runs/rings.yaml explains why: with USF they
# gain energy without bound at cfl >= 0.2, contact or not).
WORKERS = 2          # concurrent runs (the CI machine has 2 cores)


def case(name):
    return os.path.join(RUNS, f"{name}.yaml")


def run_all(tmp_path_factory, jobs):
    """Run ``{key: (case, sets)}`` two at a time; returns ``{key: output dir}``."""
    outs = {key: tmp_path_factory.mktemp(f"{key[0]}_{'_'.join(map(str, key[1:]))}")
            for key in jobs}
    with ThreadPoolExecutor(WORKERS) as pool:
        done = [pool.submit(run_pmpm, path, outs[key], 1, sets)
                for key, (path, sets) in jobs.items()]
        for future in done:
            future.result()
    return outs


# ---------------------------------------------------------------- the case files

# full-resolution particle counts per body (no run needed)
COUNTS = {
    # plane strain: 2 layers of 2,196 (the paper's 3D rings: 29,760 each)
    "rings": {"left": 4392, "right": 4392},
    # the paper: 64,000 (plane) and 49,560 (sphere)
    "sphere_rolling": {"plane": 64000, "sphere": 17256},
    # quarter model at 0.66 mm (3 plate layers); at 0.5 mm the plate gets Sec. 5.3's 398,184
    "steel_ball_plate": {"ball": 3656, "plate": 171363},
    # half model; the paper: 13,314 (rod) and 187,550 (plate)
    "ogive_plate": {"rod": 17702, "plate": 157300},
}


@pytest.mark.parametrize("name", sorted(COUNTS))
def test_case_file_validates_and_fills_the_expected_particles(name):
    loaded = load_case(case(name))
    counts = {b["name"]: len(fill_body(b, loaded["grid"])[0]) for b in loaded["bodies"]}
    assert counts == COUNTS[name]
    assert loaded["contact"]["method"] == 2                 # every case defaults to method 2


def test_steel_ball_plate_at_half_a_millimetre_has_the_papers_plate():
    loaded = load_case(case("steel_ball_plate"), ["params.cell=0.5"])
    plate = next(b for b in loaded["bodies"] if b["name"] == "plate")
    assert len(fill_body(plate, loaded["grid"])[0]) == 398184          # Sec. 5.3


@pytest.mark.parametrize("method", [0, 1, 2])
def test_method_parameter_sets_the_contact_method(method):
    for name in COUNTS:
        loaded = load_case(case(name), [f"params.method={method}"])
        assert loaded["contact"]["method"] == method


def test_touching_bodies_start_half_a_spacing_from_the_surface():
    """The sphere rests on the plane and the ball on the plate: the particle centres
    facing each other sit d/2 on either side of the contact plane."""
    for name, upper, lower, d in (("sphere_rolling", "sphere", "plane", 100.0),
                                  ("steel_ball_plate", "ball", "plate", 0.33)):
        loaded = load_case(case(name))
        z = {b["name"]: fill_body(b, loaded["grid"])[0][:, 2] for b in loaded["bodies"]}
        assert z[upper].min() - z[lower].max() == pytest.approx(d, rel=1e-9)


# ---------------------------------------------------------------- two elastic rings

RING_SPACING = 1.0


# issue 15's contact rule: no force once the gap, measured from the hat's volume shares,
# is open (docs/validation/contact_rules.md)
RELEASE_SETS = ["contact.release=0", "contact.gap=volume"]


@pytest.fixture(scope="module")
def rings(tmp_path_factory):
    jobs = {("rings", m): (case("rings"), [f"params.method={m}", "params.cfl=0.5"])
            for m in (1, 2)}
    jobs.update({("rings", f"{m}-release"): (case("rings"), [f"params.method={m}",
                                                              "params.cfl=0.5", *RELEASE_SETS])
                 for m in (1, 2)})
    return {key[1]: out for key, out in run_all(tmp_path_factory, jobs).items()}


@needs_contact
@pytest.mark.parametrize("method", [1, 2, "1-release", "2-release"])
def test_rings_bounce_apart_whole(rings, method):
    out = rings[method]
    summary = read_summary(out)
    assert summary["particles_lost"] == 0
    assert summary["n_particles"]["final"] == summary["n_particles"]["initial"]
    frame = read_frame(out)
    left = body_points(frame, body_index(out, "left"))
    right = body_points(frame, body_index(out, "right"))
    assert min_distance(left, right) > 2.0 + RING_SPACING         # more than a cell apart
    assert count_pieces(left, 1.5 * RING_SPACING) == 1
    assert count_pieces(right, 1.5 * RING_SPACING) == 1
    hist = read_history(out)
    assert hist["left.vx"][-1] < -5.0 and hist["right.vx"][-1] > 5.0  # flying apart (m/s)


@needs_contact
@pytest.mark.parametrize("method", [1, 2])
def test_rings_separate_near_the_papers_time(rings, method):
    """Seed 001: separation at about 3.4 ms (from touching; ours touch at 0.07 ms)."""
    hist = read_history(rings[method])
    t_sep = max(free_after(hist, "left"), free_after(hist, "right"))
    assert t_sep == pytest.approx(3.4, rel=0.25)


@needs_contact
def test_method_2_energy_is_smooth_where_method_1_steps(rings):
    """Seed 001 Fig. 4: at the same time-step factor (0.5) method 1's total energy is
    disturbed while the rings are in contact; method 2's stays smooth and level. After
    they separate the free rings' vibration gains a few per cent by 5 ms (cfl 0.5)."""
    hist = {m: read_history(rings[m]) for m in (1, 2)}
    one, two = (energy_steps(until_separation(hist[m], ("left", "right"))) for m in (1, 2))
    assert two["max_jump"] < 0.01                 # per history row (5 steps), of K0
    assert abs(two["drift"]) < 0.05
    assert two["max_excursion"] < 0.05
    assert one["max_jump"] > 2.0 * two["max_jump"]
    assert one["max_excursion"] > 2.0 * two["max_excursion"]
    assert abs(energy_steps(hist[2])["drift"]) < 0.1


@needs_contact
@pytest.mark.parametrize("method", [1, 2])
def test_with_the_release_rule_both_methods_keep_the_energy_level_in_contact(rings, method):
    """With the release rule method 1 keeps the energy nearly as level as method 2
    (seed 001's detection: +25 % while touching): no force at nodes whose surfaces are
    apart. Measured on 1 rank: drift -1.8 % and +0.6 %, largest excursion 4.8 % and 3.7 %,
    separating at 3.7 and 3.8 ms (later than the paper's 3.4: the contact starts only when
    the surfaces meet; docs/validation/contact_rules.md)."""
    hist = read_history(rings[f"{method}-release"])
    touching = energy_steps(until_separation(hist, ("left", "right")))
    assert abs(touching["drift"]) < 0.03
    assert touching["max_excursion"] < 0.08
    t_sep = max(free_after(hist, "left"), free_after(hist, "right"))
    assert t_sep == pytest.approx(3.4, rel=0.25)


@needs_contact
def test_rings_with_contact_on_two_ranks_give_the_one_rank_answer(tmp_path):
    # 0.2 ms: 0.13 ms in contact. Later the 1- and 2-rank runs drift apart as round-off is
    # amplified (1e-7 mm at 0.4 ms at cfl 0.1, then a contact decision flips: 0.02 mm)
    sets = ["params.method=2", "params.cfl=0.5", "time.end=0.2", "output.times=[]"]
    run_pmpm(case("rings"), tmp_path / "one", sets=sets)
    run_pmpm(case("rings"), tmp_path / "two", ranks=2, sets=sets)
    a, b = read_frame(tmp_path / "one"), read_frame(tmp_path / "two")
    assert np.array_equal(a["id"], b["id"])
    assert np.abs(a["x"] - b["x"]).max() / 80.0 < 1e-10


# ---------------------------------------------------------------- sphere on an incline

SPHERE = {"stick": (math.pi / 4, 0.4), "slip": (math.pi / 3, 0.2)}
G = 1.0e-2                      # mm/ms^2
SPHERE_CELL = 400.0
# At 0.2 m cells (scripts/sphere_rolling.py) pmpm is within 1.4 % of Eq. 36 (the issue asks
# 6 %); at 0.4 m it gave -5.0 % and -5.3 % (slip, methods 1 and 2), -9.7 % and -7.5 %
# (stick). 12 % here, which still tells stick from slip (the other regime's formula is
# 24 % and 58 % away).
SPHERE_TOLERANCE = 0.12


@pytest.fixture(scope="module")
def spheres(tmp_path_factory):
    jobs = {("sphere", name, m): (case("sphere_rolling"),
                                  [f"params.theta={theta!r}", f"params.mu={mu}",
                                   f"params.method={m}", f"params.cell={SPHERE_CELL}"])
            for name, (theta, mu) in SPHERE.items() for m in (1, 2)}
    theta, mu = SPHERE["stick"]
    jobs[("sphere", "stick", 0)] = (case("sphere_rolling"),
                                    [f"params.theta={theta!r}", f"params.mu={mu}",
                                     "params.method=0", f"params.cell={SPHERE_CELL}"])
    return {key[1:]: out for key, out in run_all(tmp_path_factory, jobs).items()}


def sphere_travel(out, name):
    theta, mu = SPHERE[name]
    t, x = travel(read_history(out), "sphere", axis=0)
    return x[-1], float(rolling_sphere_travel(t[-1], theta, mu, G)), t[-1]


def test_standard_mpm_glues_the_sphere_to_the_incline(spheres):
    moved, rigid, t_end = sphere_travel(spheres[("stick", 0)], "stick")
    assert t_end == pytest.approx(2000.0)
    assert abs(moved) < 0.1 * rigid


@needs_contact
@pytest.mark.parametrize("name", sorted(SPHERE))
@pytest.mark.parametrize("method", [1, 2])
def test_sphere_travel_matches_the_rigid_sphere(spheres, name, method):
    """Seed 001 Eq. 36 at t = 2 s (an upper bound for elastic bodies)."""
    moved, rigid, t_end = sphere_travel(spheres[(name, method)], name)
    assert t_end == pytest.approx(2000.0)
    assert moved == pytest.approx(rigid, rel=SPHERE_TOLERANCE)
    assert moved < 1.02 * rigid


# ---------------------------------------------------------------- steel ball, thin plate

# The paper's 0.66 mm cells (1 mm cells leave 2 particle layers in the plate) on a square
# plate 40 x 40 mm (a quarter 19.8 x 19.8) clamped by the fixed x+ and y+ grid faces,
# instead of the free 178 mm disc: a small free plate would just fly off with the ball.
# 180 us instead of 240: by 120 us the contact balls have left the hole at their final
# speed (within 0.1 m/s) and standard MPM's is below 0.1 v0 by 180 us (5.6 m/s).
BALL_SETS = ["params.plate_radius=19.14", "grid.boundary.x+=fixed", "grid.boundary.y+=fixed",
             "bodies.1.geometry={type: box, min: [0, 0, -1], max: [19.8, 19.8, 0]}",
             "time.end=0.18", "output.frames=3"]
BALL_SPACING = 0.33
V0_BALL = 200.0


@pytest.fixture(scope="module")
def balls(tmp_path_factory):
    jobs = {("ball", m): (case("steel_ball_plate"), BALL_SETS + [f"params.method={m}"])
            for m in (0, 1, 2)}
    jobs["ball", "paper"] = (case("steel_ball_plate"),
                             BALL_SETS + ["params.method=2", "contact.separation=none"])
    return {key[1]: out for key, out in run_all(tmp_path_factory, jobs).items()}


def plate_measures(out):
    plate = body_points(read_frame(out), body_index(out, "plate"))
    return perforation(plate, BALL_SPACING, axis=2, centre=(0.0, 0.0), thickness=1.0)


def ball_residual_velocity(out):
    """The ball's downward mass-weighted velocity at the end (m/s)."""
    return -read_history(out)["ball.vz"][-1]


def test_standard_mpm_does_not_perforate_the_plate(balls):
    """Seed 001 Fig. 7: the shared velocity field's no-slip contact stops the ball."""
    measures = plate_measures(balls[0])
    assert not measures["perforated"]
    assert measures["n_pieces"] == 1
    assert ball_residual_velocity(balls[0]) < 0.1 * V0_BALL


@needs_contact
@pytest.mark.parametrize("method", [1, 2])
def test_contact_methods_perforate_the_plate(balls, method):
    """Seed 001 Figs. 8-10, Table II: the ball leaves through a hole at V_r 50 to 90 m/s,
    h/D 0.85 to 0.99 over cells of 0.66 to 0.5 mm (experiment: h/D = 0.84); wider bands
    here for the small clamped plate. Perforated: the plate's main piece has a hole
    (pmpm.post.perforation) and the ball still moves on at more than 0.1 v0."""
    measures = plate_measures(balls[method])
    assert measures["perforated"]
    v_r = ball_residual_velocity(balls[method])
    assert 30.0 < v_r < 120.0
    assert 0.6 < measures["h_over_D"] < 1.3


@needs_contact
def test_the_separation_check_stops_the_plate_braking_the_ball_across_a_gap(balls):
    """The case's separation check (0.9 cells) against the paper's detection, method 2:
    without the check the rim brakes the ball from up to a cell away, so the ball leaves
    slower (48.0 against 103.6 m/s here; on the full free plate it is held: README,
    steel ball)."""
    assert ball_residual_velocity(balls[2]) > 1.5 * ball_residual_velocity(balls["paper"])


# ---------------------------------------------------------------- ogive rod, oblique plate

# 2 mm cells as in the paper, but a 60 x 60 mm plate instead of 110 x 110 (its edges 30 mm
# from the rod's path), 1 mm rod spacing and 0.2 ms (the rod's speed is within 1 % of its
# final value by then at full size)
OGIVE_SETS = ["params.v0=575", "params.ppc_rod=2", "time.end=0.2",
              "bodies.1.geometry.min=[-22, 0, -26.3]", "bodies.1.geometry.max=[38, 30, 0]"]
OGIVE_DIRECTION = (0.0, 0.0, -1.0)                  # the case's rod flies along -z
PLATE_NORMAL = (math.sin(math.radians(30)), 0.0, math.cos(math.radians(30)))
# Table IV at 575 m/s: experiment 455, standard MPM 334.1, methods 1 and 2: 442.8, 453.4.
# The full run (scripts/ogive_plate.py) must be within 5 % of 455 (it gives 444.3); 10 %
# here (446.7). Standard MPM gives 334.3 at full size; on this small plate, which holds
# less of the rod's shank, 377.7: below 0.85 x 455 = 386.8.
OGIVE_TOLERANCE = 0.10
STANDARD_MPM_BELOW = 0.85


@pytest.fixture(scope="module")
def ogives(tmp_path_factory):
    jobs = {("ogive", m): (case("ogive_plate"), OGIVE_SETS + [f"params.method={m}"])
            for m in (0, 2)}
    return {key[1]: out for key, out in run_all(tmp_path_factory, jobs).items()}


def test_standard_mpm_slows_the_rod_far_below_the_experiment(ogives):
    hist = read_history(ogives[0])
    assert hist["time"][-1] == pytest.approx(0.2)
    assert residual_velocity(hist, "rod") < STANDARD_MPM_BELOW * 455.0


@needs_contact
def test_method_2_residual_velocity_matches_the_experiment(ogives):
    hist = read_history(ogives[2])
    centroid = (hist["rod.x"][-1], hist["rod.y"][-1], hist["rod.z"][-1])
    assert np.dot(PLATE_NORMAL, centroid) < -26.3           # its centre has left the plate
    assert residual_velocity(hist, "rod") == pytest.approx(455.0, rel=OGIVE_TOLERANCE)
    assert residual_velocity(hist, "rod", OGIVE_DIRECTION) > 0.9 * residual_velocity(hist, "rod")


@needs_contact
def test_contact_lets_the_rod_out_faster_than_standard_mpm(ogives):
    # Table IV at 575 m/s: 334.1 against 453.4 (0.74); here 377.7 against 446.7 (0.85)
    standard = residual_velocity(read_history(ogives[0]), "rod")
    contact = residual_velocity(read_history(ogives[2]), "rod")
    assert standard < 0.9 * contact
