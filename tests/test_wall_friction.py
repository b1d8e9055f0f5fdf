"""Coulomb friction on a slip face of the grid box (issue 14): an elastic block on an
inclined plane (gravity tilted by the angle a) accelerates at g (sin a - mu cos a) while
it slides and does not creep when mu > tan a; 2 ranks give the 1-rank answer; friction
on a face that is not a slip face is refused naming the key
(tests/cases/wall_friction.yaml, docs/validation/wall_friction.md)."""
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


@pytest.mark.parametrize("face, condition", [("z-", "fixed"), ("x+", "free"),
                                             ("y-", "symmetry")])
def test_friction_on_a_face_that_is_not_slip_is_refused(tmp_path, face, condition):
    done = pmpm([CASE, "--out", str(tmp_path / "o"), "--set",
                 f"grid.boundary.{face}={condition}", "--set", f"grid.friction.{face}=0.3"])
    assert done.returncode == 2
    assert f"grid.friction.{face}: friction 0.3 on a {condition} face" in done.stderr
