"""Coulomb friction on a slip face of the grid box (issue 14): an elastic block on an
inclined plane (gravity tilted by the angle a) accelerates at g (sin a - mu cos a) while
it slides and does not creep when mu > tan a; 2 ranks give the 1-rank answer; friction
on a face that is not a slip face is refused naming the key
(tests/cases/wall_friction.yaml, docs/validation/wall_friction.md)."""
import json
import math
import os

import numpy as np
import pytest

from clihelp import pmpm, read_history
from runhelp import CASES, run_pmpm
from test_shape_functions import _same_answer

CASE = os.path.join(CASES, "wall_friction.yaml")
G = 10.0


def acceleration(out):
    """Slope of the block's velocity along the slope over the run (m/s^2), and its
    largest speed."""
    header, rows = read_history(str(out))
    t, v = rows[:, header.index("time")], rows[:, header.index("block.vx")]
    return np.polyfit(t, v, 1)[0], np.abs(v).max()


#: measured (gimp, USF, cfl 0.5): -0.03 % (mu 0.1), -0.24 % (mu 0.3), +0.16 % (mu 0.2,
#: horizontal, from 1 m/s); the issue asks 2 %
@pytest.mark.parametrize("mu, angle, v0", [(0.1, 30, 0.0), (0.3, 30, 0.0), (0.2, 0, 1.0)])
def test_a_sliding_block_accelerates_at_g_sin_minus_mu_g_cos(tmp_path, mu, angle, v0):
    run_pmpm(CASE, tmp_path, sets=[f"params.mu={mu}", f"params.angle_deg={angle}",
                                   f"params.v0={v0}"])
    a = math.radians(angle)
    exact = G * (math.sin(a) - mu * math.cos(a))
    measured, _ = acceleration(tmp_path)
    assert measured == pytest.approx(exact, rel=0.02)
    friction_work_closes_the_balance(tmp_path, mu, a, v0, exact)


def friction_work_closes_the_balance(out, mu, angle, v0, acceleration):
    """The wall's friction work (history.csv's dissipated, the sum of forces.csv's faces'
    ``.dissipated``) is the friction force times the distance slid, m mu g cos(a) (v0 t
    + a_s t^2 / 2), within 4 % (measured -0.5, -3.3 and -1.1 % for the three cases: the
    block, dropped unstressed, rocks, and where a node of its base sticks for a moment
    its friction does no work); with it the energy balance (kinetic + internal +
    dissipated - the work of gravity) closes within 2 % of the energy the block was
    given (measured 0.3, 1.5 and 0.8 %; 17, 50 and 75 % go unaccounted without it)."""
    header, rows = read_history(str(out))
    col = {name: rows[:, k] for k, name in enumerate(header)}
    forces = np.genfromtxt(os.path.join(out, "forces.csv"), delimiter=",", names=True,
                           deletechars="")
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        m = json.load(f)["bodies"]["block"]["mass"]
    end = col["time"][-1]
    slid = v0 * end + 0.5 * acceleration * end ** 2
    assert col["dissipated"][-1] == pytest.approx(m * mu * G * math.cos(angle) * slid,
                                                  rel=0.04)
    faces = sum(forces[c][-1] for c in forces.dtype.names if c.endswith(".dissipated"))
    assert faces == pytest.approx(col["dissipated"][-1], rel=1e-12)
    work = m * G * (math.sin(angle) * (col["block.x"] - col["block.x"][0])
                    - math.cos(angle) * (col["block.z"] - col["block.z"][0]))
    balance = col["total"] + col["dissipated"] - work
    given = max(col["total"][0], work.max())
    assert np.abs(balance - balance[0]).max() < 0.02 * given
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        watch = json.load(f)["energy_balance"]       # the watch counts the friction work
    assert not watch["warned_loss"] and watch["largest_loss"] < 0.05    # 2.3 % at most


def test_a_block_with_mu_above_tan_a_does_not_creep(tmp_path):
    """mu 0.7 > tan 30 deg = 0.577: after the elastic settling of the first 0.04 s
    (0.07 mm) the block stays within 0.1 um (measured 0.07 um). With pure FLIP (time.pic 0) the block,
    dropped on the wall unstressed, rings, and the wall, which stops only motion into
    it, lets the ringing lift it node by node: it creeps at up to 0.05 m/s (documented);
    a little PIC (0.1) damps the ringing."""
    run_pmpm(CASE, tmp_path, sets=["params.mu=0.7", "time.pic=0.1"])
    header, rows = read_history(str(tmp_path))
    t, x = rows[:, header.index("time")], rows[:, header.index("block.x")]
    late = t > 0.1
    assert np.ptp(x[late]) < 1e-6
    assert abs(x[-1] - x[0]) < 1e-4            # sliding at mu 0.5 would go 20 mm
def test_without_friction_the_block_slides_freely(tmp_path):
    run_pmpm(CASE, tmp_path, sets=["params.mu=0"])
    measured, _ = acceleration(tmp_path)
    assert measured == pytest.approx(G * 0.5, rel=1e-6)


def test_two_ranks_give_the_one_rank_answer(tmp_path):
    sets = ["params.mu=0.3"]
    run_pmpm(CASE, tmp_path / "one", sets=sets)
    run_pmpm(CASE, tmp_path / "two", ranks=2, sets=sets)
    _same_answer(tmp_path / "one", tmp_path / "two", 1.2)
    one, two = (read_history(str(tmp_path / n)) for n in ("one", "two"))
    k = one[0].index("dissipated")
    assert one[1][-1, k] > 0.0
    assert np.allclose(one[1][:, k], two[1][:, k], rtol=1e-9, atol=0.0)


@pytest.mark.parametrize("face, condition", [("z-", "fixed"), ("x+", "free"),
                                             ("y-", "symmetry")])
def test_friction_on_a_face_that_is_not_slip_is_refused(tmp_path, face, condition):
    done = pmpm([CASE, "--out", str(tmp_path / "o"), "--set",
                 f"grid.boundary.{face}={condition}", "--set", f"grid.friction.{face}=0.3"])
    assert done.returncode == 2
    assert f"grid.friction.{face}: friction 0.3 on a {condition} face" in done.stderr
