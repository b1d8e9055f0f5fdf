"""A change that must not move any answer (the solver's restructure, a speed-up) leaves
the final state of coarse versions of every case in runs/ bit-identical on 1 and on 2
ranks: the fingerprints in tests/golden/answers.json were made on the code before it
(tests/golden_answers.py, which also says how to re-make them on purpose)."""
import json

import pytest

from golden_answers import COARSE, GOLDEN, RANKS, run_fingerprint

with open(GOLDEN, encoding="utf-8") as handle:
    ANSWERS = json.load(handle)


def test_every_coarse_case_has_a_fingerprint():
    assert sorted(ANSWERS) == sorted(COARSE)


@pytest.mark.parametrize("ranks", RANKS)
@pytest.mark.parametrize("name", sorted(COARSE))
def test_final_state_is_bit_identical_to_the_code_before(tmp_path, name, ranks):
    expected = ANSWERS[name][str(ranks)]
    got = run_fingerprint(name, ranks, str(tmp_path))
    assert got["n"] == expected["n"]
    assert got["sha256"] == expected["sha256"], (
        f"{name} on {ranks} rank(s) moved: sum of x {got['x_sum']!r} against "
        f"{expected['x_sum']!r}, sum of v {got['v_sum']!r} against {expected['v_sum']!r}")
