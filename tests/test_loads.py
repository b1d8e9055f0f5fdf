"""Body forces, point loads with time functions and rigid bodies against closed forms."""
import textwrap

import pytest

from pmpm.post import read_summary
from runhelp import run_pmpm

BLOCK = """
grid: {{min: [0, 0, 0], max: [12, 12, 12], cell: 1.0}}
materials:
  soft: {{model: elastic, density: 1.0e-3, E: 1000.0, nu: 0.3}}
  wall: {{model: rigid, density: 7.8e-3}}
bodies:
  - {{name: block, material: soft, geometry: {{type: box, min: [4, 4, 4], max: [8, 8, 8]}}}}
{extra}
time: {{end: {end}, cfl: 0.5}}
output: {{frames: 2, history_every: 5}}
"""


def run_text(tmp_path, text, **kw):
    case = tmp_path / "case.yaml"
    case.write_text(textwrap.dedent(text))
    run_pmpm(str(case), tmp_path / "out", **kw)
    return read_summary(tmp_path / "out")


def test_free_fall_under_gravity(tmp_path):
    g, t = 100.0, 0.02
    s = run_text(tmp_path, BLOCK.format(extra=f"gravity: [0, 0, {-g}]", end=t))
    block = s["bodies"]["block"]
    assert block["velocity"][2] == pytest.approx(-g * t, rel=1e-9)
    # x_{k+1} = x_k + dt v_{k+1} (Eq. 15) falls g t dt / 2 further than g t^2 / 2
    dt = t / s["n_steps"]
    drop = 6.0 - block["centroid"][2]
    assert drop - 0.5 * g * t * t == pytest.approx(0.5 * g * t * dt, rel=0.05)


def test_point_force_with_a_ramp_gives_the_impulse(tmp_path):
    force, rise, t = 5.0, 0.01, 0.02
    load = f"""loads:
  - {{name: push, body: block, type: force, region: {{min: [7.5, 4, 4], max: [8, 8, 8]}},
      value: [{force}, 0, 0], time_function: {{type: ramp, t_rise: {rise}}}}}"""
    s = run_text(tmp_path, BLOCK.format(extra=load, end=t))
    block = s["bodies"]["block"]
    impulse = force * (t - 0.5 * rise)                  # integral of the ramped force
    assert block["mass"] * block["velocity"][0] == pytest.approx(impulse, rel=2e-3)


@pytest.mark.parametrize("ranks", [1, 2])
def test_rigid_body_moves_with_its_velocity_and_pushes(tmp_path, ranks):
    t, v = 0.02, 50.0
    wall = """  - {name: pusher, material: wall, velocity: [50, 0, 0],
     geometry: {type: box, min: [1, 4, 4], max: [3.5, 8, 8]}}"""
    case = tmp_path / "case.yaml"
    case.write_text(BLOCK.format(extra=wall, end=t))
    run_pmpm(str(case), tmp_path / "out", ranks=ranks)
    s = read_summary(tmp_path / "out")
    pusher, block = s["bodies"]["pusher"], s["bodies"]["block"]
    assert pusher["centroid"][0] == pytest.approx(2.25 + v * t, rel=1e-12)
    assert pusher["velocity"] == pytest.approx([v, 0, 0], abs=1e-12)
    assert block["velocity"][0] > 0.2 * v                # pushed along
