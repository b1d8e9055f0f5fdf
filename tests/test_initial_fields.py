"""Initial conditions as functions of position: a body's velocity components and its
temperature may be expressions of x, y, z, evaluated per particle when it is filled."""
import numpy as np
import pytest

from clihelp import pmpm, pmpm_lines, run_ok
from pmpm.case import CaseError, validate_case
from pmpm.case.expressions import evaluate_field
from pmpm.post import read_frame
from runhelp import CASES

CASE = f"{CASES}/initial_fields.yaml"


def test_a_field_is_evaluated_at_every_position():
    x = np.array([[0.0, 1.0, 2.0], [3.0, -1.0, 0.5]])
    values = evaluate_field("2 * x + y ** 2 - max(z, 1) + sin(pi * x / 6)", x)
    assert values == pytest.approx([1.0 + 0.0 - 2.0 + 0.0, 6.0 + 1.0 - 1.0 + 1.0])


def body_case(**body):
    return {"grid": {"min": [0, 0, 0], "max": [4, 4, 4], "cell": 1.0},
            "materials": {"m": {"model": "elastic", "density": 1e-3, "E": 1e3, "nu": 0.3}},
            "bodies": [{"name": "b", "material": "m",
                        "geometry": {"type": "box", "min": [1, 1, 1], "max": [2, 2, 2]},
                        **body}],
            "time": {"end": 1.0}}


@pytest.mark.parametrize("body, message", [
    ({"velocity": ["q * x", 0, 0]}, "bodies[0].velocity[0]: 'q * x' refers to q"),
    ({"velocity": [0, "sin(", 0]}, "bodies[0].velocity[1]: invalid expression"),
    ({"velocity": [0, 0, "foo(x)"]}, "bodies[0].velocity[2]: unknown function 'foo'"),
    ({"temperature": "t + 1"}, "bodies[0].temperature: 't + 1' refers to t"),
    ({"velocity": [0, 0]}, "bodies[0].velocity: expected a list of 3 numbers or "
                           "expressions"),
])
def test_a_bad_field_names_its_key(body, message):
    with pytest.raises(CaseError) as error:
        validate_case(body_case(**body), check_geometry=False)
    assert any(line.startswith(message) for line in error.value.problems), \
        error.value.problems


@pytest.mark.parametrize("ranks", [1, 2])
def test_velocity_and_temperature_follow_their_expressions(tmp_path, ranks):
    run_ok([CASE, "--out", tmp_path, "--set", "decomposition.axis=x"], ranks)
    start = read_frame(tmp_path, 0)
    x = start["x"][:, 0]
    assert start["v"][:, 0] == pytest.approx(np.sin(np.pi * x / 40.0), abs=1e-14)
    assert np.all(start["v"][:, 1:] == 0.0)
    assert start["temp"] == pytest.approx(300.0 + x, abs=1e-12)


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_field_that_is_not_finite_is_one_error_line(tmp_path, ranks):
    done = pmpm([CASE, "--out", tmp_path, "--set", "decomposition.axis=x",
                 "--set", 'bodies[0].velocity=["log(x - 15)", 0, 0]'], ranks)
    assert done.returncode == 2
    assert pmpm_lines(done.stderr) == [
        "pmpm: error: bodies[0].velocity[0]: 'log(x - 15)' is not finite at some particles "
        "of the body"]


def test_without_a_temperature_the_material_reference_is_used(tmp_path):
    copper = ("{model: johnson_cook, density: 8.93e-3, E: 117e3, nu: 0.35, A: 157, B: 425, "
              "n: 1.0, C: 0, T_room: 350}")
    run_ok([CASE, "--out", tmp_path, "--set", "bodies[0].temperature=null",
            "--set", f"materials.m={copper}"])
    assert np.all(read_frame(tmp_path, 0)["temp"] == 350.0)
