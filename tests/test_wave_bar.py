"""Elastic wave in a 100 mm bar, seed 000 Sec. 5.1, against the 1D solution at 7.6, 15.6
and 41.6 us; coarse cells (1 and 0.5 mm) on a bar two cells wide (slip faces: 1D)."""
import os

import numpy as np
import pytest

from pmpm.post import axial_profiles, rms_error, wave_bar_stress
from runhelp import RUNS, run_pmpm

CASE = os.path.join(RUNS, "wave_bar.yaml")
C = np.sqrt(1.0e5 / 5.0e-3)          # mm/ms: E = 100 GPa, rho = 5000 kg/m^3 -> 4472.1 m/s
LOAD = -2.5 / 36.0                   # MPa, compressive
TIMES = (0.0076, 0.0156, 0.0416)


def profiles(out):
    """{time: (x, sigma_xx)} sorted along the bar, for the three comparison times."""
    result = axial_profiles(out, TIMES)
    assert sorted(result) == list(TIMES)
    return result


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    outs = {}
    for cell in (1.0, 0.5):
        outs[cell] = tmp_path_factory.mktemp(f"wave{cell}")
        run_pmpm(CASE, outs[cell], sets=[f"params.cell={cell}", f"params.width={2 * cell}"])
    return outs


def errors(out):
    return {t: rms_error(s, wave_bar_stress(x, t, 100.0, C, LOAD), LOAD)
            for t, (x, s) in profiles(out).items()}


def test_rms_error_falls_as_the_cell_shrinks(runs):
    coarse, fine = errors(runs[1.0]), errors(runs[0.5])
    for t in TIMES:
        assert fine[t] < coarse[t]
        assert coarse[t] < 0.2                          # RMS / load stress


def test_plateaus_match_the_load_and_its_reflection(runs):
    h = 0.5
    prof = profiles(runs[h])
    x, s = prof[0.0076]
    front = 100.0 - C * 0.0076
    assert np.mean(s[x > front + 6 * h]) == pytest.approx(LOAD, rel=0.02)
    assert np.abs(s[x < front - 6 * h]).max() < 0.02 * abs(LOAD)
    x, s = prof[0.0416]
    reflected = C * 0.0416 - 100.0
    assert np.mean(s[x < reflected - 6 * h]) == pytest.approx(2 * LOAD, rel=0.03)


def test_wave_front_travels_at_the_bar_speed(runs):
    x, s = profiles(runs[0.5])[0.0156]
    half = x[np.argmax(s < 0.5 * LOAD)]            # first point (from x = 0) past half load
    assert half == pytest.approx(100.0 - C * 0.0156, abs=1.0)


def test_two_ranks_give_the_one_rank_answer(runs, tmp_path):
    run_pmpm(CASE, tmp_path, ranks=2, sets=["params.cell=0.5", "params.width=1.0"])
    for t in TIMES:
        (x1, s1), (x2, s2) = profiles(runs[0.5])[t], profiles(tmp_path)[t]
        assert np.abs(x1 - x2).max() < 1e-10 * 100.0
        assert np.abs(s1 - s2).max() < 1e-10 * abs(LOAD) * 10


def test_musl_order_gives_the_1d_solution_as_usf_does(runs, tmp_path):
    """time.scheme = musl (stresses from the updated particle velocities mapped back to
    the grid): the same wave within the same error as update-stress-first."""
    run_pmpm(CASE, tmp_path, sets=["params.cell=1.0", "params.width=2.0", "time.scheme=musl"])
    musl, usf = errors(tmp_path), errors(runs[1.0])
    for t in TIMES:
        assert musl[t] < 0.2 and musl[t] < 1.2 * usf[t]
        assert musl[t] != usf[t]                        # it did run another update order
