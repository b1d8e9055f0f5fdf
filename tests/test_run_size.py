"""The run's size, estimated before the kernels compile (issue 17): particles, time steps
(end time over the first time step) and output bytes, printed before the run; a run of
more than time.max_steps steps, or whose output would not fit on the disk, is refused
with exit 2 naming the key."""
import os
import re

import pytest

from clihelp import BAR, pmpm, pmpm_lines, run_ok
from pmpm.case import load_config
from pmpm.case.fill import fill_body
from pmpm.io.summary import read_summary
from pmpm.solver.bodies import fill_positions
from pmpm.solver.estimate import estimate, initial_speed, size_problems

LINE = re.compile(r"^pmpm: ([\d,]+) particles; about ([\d,]+) steps \((?:cfl \S+: first|"
                  r"fixed) time step \S+\); output about ([\d.]+) (kB|MB) in (\d+) frames? \(.* free\)$", re.M)


def bar_size(*sets):
    config = load_config(BAR, sets)
    filled = fill_positions(config, fill_body, os.path.dirname(BAR))
    n = sum(len(v) for _, v in filled)
    return config, estimate(config, n, initial_speed(config, filled))


def test_the_estimate_of_the_cli_bar_is_close():
    config, size = bar_size()
    assert size.particles == 624 and size.frames == 3
    assert 48 <= size.steps <= 52          # the run takes 48
    assert size.first_dt == pytest.approx(1.067e-4, rel=0.01)
    assert size_problems(config, size, free_bytes=10 ** 12) == []


def test_a_run_prints_its_size_first_and_it_is_about_right(tmp_path):
    out = tmp_path / "out"
    done = run_ok([BAR, "--out", out])
    match = LINE.search(done.stdout)
    assert match and done.stdout.startswith(match.group(0)), done.stdout[:300]
    n, steps, size, unit, frames = match.groups()
    assert int(n.replace(",", "")) == 624 and int(frames) == 3
    assert abs(int(steps) - read_summary(out)["n_steps"]) <= 2
    written = sum(os.path.getsize(out / name) for name in os.listdir(out))
    estimated = float(size) * (1e3 if unit == "kB" else 1e6)
    # three checkpoints counted (two kept and one being written) where two remain
    assert 0.9 * written <= estimated <= 1.5 * written, (written, estimated)


@pytest.mark.parametrize("sets, words", [
    (["time.end=1e300"], "time.end: 1e+300 takes about"),
    (["params.v0=1e30"], "time.end: 0.005 takes about 1e+28 time steps"),
    (["time.max_steps=20"], "time.end: 0.005 takes about 49 time steps"),
])
def test_a_run_that_cannot_finish_is_refused(tmp_path, sets, words):
    out = tmp_path / "out"
    done = pmpm([BAR, "--out", out] + [x for s in sets for x in ("--set", s)], timeout=30)
    assert done.returncode == 2, done.stderr
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1 and lines[0].startswith("pmpm: error: " + words), lines
    assert "raise time.max_steps" in lines[0] and done.stdout == ""
    assert not out.exists() or not any(out.iterdir())


def test_time_max_steps_lets_a_long_run_go(tmp_path):
    run_ok([BAR, "--out", tmp_path / "out", "--quiet", "--set", "time.max_steps=60"])


def test_output_beyond_the_free_disk_space_is_refused():
    config, size = bar_size()
    problems = size_problems(config, size, free_bytes=100_000)
    assert len(problems) == 1 and problems[0].startswith(
        "output.frames: the run would write about "), problems
    assert "(3 frames of 624 particles, checkpoints, history)" in problems[0]
    assert "but the output directory has 100 kB free" in problems[0]


def test_a_restart_estimates_what_is_left(tmp_path):
    out = tmp_path / "out"
    run_ok([BAR, "--out", out, "--quiet", "--set", "time.end=0.0025"])
    done = run_ok([BAR, "--out", out, "--restart", "--set", "time.end=0.005"])
    match = LINE.search(done.stdout)
    assert match, done.stdout[:300]
    assert 22 <= int(match.group(2)) <= 26 and int(match.group(5)) == 1   # 24 steps left
    done = pmpm([BAR, "--out", out, "--restart", "--set", "time.end=1e30"])
    assert done.returncode == 2
    assert pmpm_lines(done.stderr)[0].startswith("pmpm: error: time.end: 1e+30 takes about")
