"""Issue 17: a slab decomposition that cannot be made is one input error naming
decomposition.axis; a bad parameter reports only its own problem; plurals read right."""
import numpy as np
import pytest

from clihelp import pmpm, pmpm_lines, BAR
from pmpm.case import CaseError, load_config
from pmpm.comm.slabs import choose_slabs
from pmpm.solver.errors import SetupError

THIN_Z = [np.ones(8), np.ones(8), np.ones(1)]
CUBE = [np.ones(3)] * 3
Z_LINE = ("decomposition.axis: z has 1 cell layer: it can be split among at most 1 rank "
          "(2 ranks asked); choose another axis or fewer ranks")


def test_fixed_axis_too_thin_names_key_and_rank_limit():
    with pytest.raises(SetupError) as error:
        choose_slabs(THIN_Z, 2, "z")
    assert error.value.problems == [Z_LINE]


def test_auto_names_the_largest_rank_count_any_axis_takes():
    with pytest.raises(SetupError) as error:
        choose_slabs(CUBE, 4, "auto")
    assert error.value.problems == [
        "decomposition.axis: auto: no axis has more than 3 cell layers: it can be split "
        "among at most 3 ranks (4 ranks asked); use fewer ranks"]


def test_auto_still_picks_an_axis_that_fits():
    assert choose_slabs(THIN_Z, 2, "auto").axis in (0, 1)
    assert choose_slabs(CUBE, 3, "auto").size == 3


def test_cli_prints_the_decomposition_error_once_and_exits_2(tmp_path):
    done = pmpm(["runs/rings.yaml", "--set", "decomposition.axis=z", "--out", tmp_path / "o"],
                ranks=2)
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr) == [f"pmpm: error: {Z_LINE}"]
    assert "Traceback" not in done.stderr


def problems_of(*overrides):
    with pytest.raises(CaseError) as error:
        load_config(BAR, list(overrides))
    return error.value.problems


def test_bad_parameter_reports_only_its_own_line():
    assert problems_of("params.cell=abc") == [
        "params.cell: a parameter must be a finite number, got 'abc'"]


def test_parameter_depending_on_a_bad_one_reports_nothing_more():
    assert problems_of("params.cell=abc", "params.v0=${2*cell}") == [
        "params.cell: a parameter must be a finite number, got 'abc'"]


def test_parameters_in_a_cycle_report_only_the_cycle():
    assert problems_of("params.cell=${v0}", "params.v0=${cell}") == [
        "params: parameters refer to each other in a cycle: cell, v0"]


def test_list_of_at_least_one_body_is_singular():
    assert problems_of("bodies=[]") == ["bodies: expected a list of at least 1 body, got list []"]
