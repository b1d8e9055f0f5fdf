"""Bodies that overlap (issue 17) are one input error per pair naming both bodies: their
mass would count twice where they overlap. Touching bodies are accepted."""
import pytest

from clihelp import pmpm, pmpm_lines
from pmpm.case import CaseError, load_case

HEAD = """\
grid: {min: [0, 0, 0], max: [10, 10, 10], cell: 1}
materials: {m: {model: elastic, density: 1.0e-3, E: 100, nu: 0.3}}
time: {end: 1}
bodies:
  - {name: a, material: m, geometry: {type: box, min: [1, 1, 1], max: [5, 5, 5]}}
"""


def case(tmp_path, *bodies):
    path = tmp_path / "case.yaml"
    path.write_text(HEAD + "".join(f"  - {b}\n" for b in bodies), encoding="utf-8")
    return path


def problems(path):
    with pytest.raises(CaseError) as err:
        load_case(path)
    return err.value.problems


def test_a_sphere_over_two_boxes_gives_one_line_per_pair(tmp_path):
    path = case(tmp_path,
                "{name: b, material: m, geometry: {type: sphere, center: [5, 5, 5], radius: 2}}",
                "{name: c, material: m, geometry: {type: box, min: [5, 5, 5], max: [9, 9, 9]}}")
    assert problems(path) == [
        "bodies[1].geometry: body 'b' overlaps body 'a' (bodies[0]): 35 particles of 'b' "
        "(volume 4.38) lie inside 'a'; bodies may not overlap",
        "bodies[2].geometry: body 'c' overlaps body 'b' (bodies[1]): 35 particles of 'c' "
        "(volume 4.38) lie inside 'b'; bodies may not overlap"]   # a and c touch: fine


def test_touching_bodies_and_a_ring_around_a_rod_are_accepted(tmp_path):
    path = case(tmp_path,
                "{name: b, material: m, geometry: {type: box, min: [5, 1, 1], max: [9, 5, 5]}}",
                "{name: ring, material: m, geometry: {type: cylinder, base: [7, 7, 6], "
                "axis: z, radius: 2, inner_radius: 1, length: 2}}",
                "{name: rod, material: m, geometry: {type: cylinder, base: [7, 7, 5], "
                "axis: z, radius: 1, length: 4}}")
    assert [b["name"] for b in load_case(path)["bodies"]] == ["a", "b", "ring", "rod"]


def test_a_body_inside_another_is_found_either_way(tmp_path):
    path = case(tmp_path,
                "{name: core, material: m, geometry: {type: sphere, center: [3, 3, 3], "
                "radius: 1}}")
    [line] = problems(path)
    assert line.startswith("bodies[1].geometry: body 'core' overlaps body 'a' (bodies[0]): ")
    # a small fine sphere listed first, between a's particles: only its own are inside a
    path.write_text(path.read_text().replace(
        "  - {name: a,", "  - {name: bead, material: m, particles_per_cell: 8, geometry: "
        "{type: sphere, center: [3, 3, 3], radius: 0.2}}\n  - {name: a,"))
    assert problems(path)[0] == (
        "bodies[1].geometry: body 'a' overlaps body 'bead' (bodies[0]): 8 particles of "
        "'bead' (volume 0.0156) lie inside 'a'; bodies may not overlap")


@pytest.mark.parametrize("angle, overlap", [(0, False), (30, False), (-30, True)])
def test_rotation_is_taken_into_account(tmp_path, angle, overlap):
    """A box touching a's face at x = 5, turned about its corner (5, 4) by -30 deg,
    swings into a; by +30 deg it swings away."""
    path = case(tmp_path, "{name: e, material: m, geometry: {type: box, min: [5, 1, 1], "
                f"max: [8, 4, 4], rotate: {{axis: [0, 0, 1], angle_deg: {angle}, "
                "origin: [5, 4, 1]}}}")
    if overlap:
        [line] = problems(path)
        assert line.startswith("bodies[1].geometry: body 'e' overlaps body 'a' (bodies[0])")
    else:
        load_case(path)


def test_the_command_line_says_it_once_on_2_ranks(tmp_path):
    path = case(tmp_path,
                "{name: b, material: m, geometry: {type: sphere, center: [5, 5, 5], radius: 2}}")
    done = pmpm([path, "--out", tmp_path / "out"], ranks=2)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert pmpm_lines(done.stderr) == [
        "pmpm: error: bodies[1].geometry: body 'b' overlaps body 'a' (bodies[0]): 35 "
        "particles of 'b' (volume 4.38) lie inside 'a'; bodies may not overlap"]
