"""Hertz: two elastic spheres meeting head-on (issue 15; docs/validation/hertz.md).

The contact patch of tests/cases/hertz.yaml spans 4 window cells (0.5 mm coarse cells,
a ratio-2 window): with the volume gap the peak force, contact time and largest approach
must be within 10 % of Hertz's, on 2 ranks (the slab plane crosses the spheres)."""
import os

import pytest

from runhelp import CASES, run_pmpm
from pmpm.post import hertz_answer, hertz_measures

CASE = os.path.join(CASES, "hertz.yaml")
RADIUS = 5.0
ANSWER = hertz_answer(RADIUS, 7.85e-3, 2.0e5, 0.3, 50.0)


def test_exact_hertz_numbers_of_the_case():
    assert ANSWER.approach == pytest.approx(0.4149, rel=1e-3)
    assert ANSWER.force == pytest.approx(61915, rel=1e-3)
    assert ANSWER.contact_time == pytest.approx(12.21e-3, rel=1e-3)


def test_volume_gap_meets_hertz_within_ten_percent(tmp_path):
    run_pmpm(CASE, tmp_path, 2, [])
    measured = hertz_measures(tmp_path, ANSWER, RADIUS)
    for key in ("force", "contact_time", "approach"):
        assert abs(measured[key]) < 0.10, (key, measured)
    assert measured["rebound"] > 0.93, measured          # they part, little left ringing
    assert abs(measured["energy"]) < 0.05, measured
