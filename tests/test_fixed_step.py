"""time.dt, a fixed time step (issue 24; seed 004 Table 6 runs at 1 to 4e-5 ms): the run
takes exactly end / dt steps of dt (landing on the output times), a dt above the stable
step at the start is refused naming the key, and one the step falls below later stops
the run with a fault instead of blowing up."""
import json
import os
import re

import numpy as np
import pytest

from clihelp import BAR, ROOT, frame_list, pmpm, pmpm_lines, read_history, run_ok
from pmpm.case import CaseError, load_case


def test_a_fixed_step_takes_exactly_the_steps_expected(tmp_path):
    """cli_bar (end 0.005 ms, a frame at 0.0025) at dt = 1e-4: 50 steps, each of 1e-4
    (at its cfl 0.5 it takes 48 steps of about 1.04e-4)."""
    out = tmp_path / "out"
    run_ok([BAR, "--out", out, "--quiet", "--set", "time.dt=1e-4",
            "--set", "output.history_every=1"])
    assert [step for _, step in frame_list(out)] == [0, 25, 50]
    header, rows = read_history(out)
    assert rows[-1, header.index("step")] == 50
    assert rows[-1, header.index("time")] == pytest.approx(0.005, rel=1e-12)
    assert np.allclose(rows[1:, header.index("dt")], 1e-4, rtol=1e-9, atol=0)


def test_a_fixed_step_above_the_stable_one_is_refused_naming_the_key(tmp_path):
    done = pmpm([BAR, "--out", tmp_path / "out", "--quiet", "--set", "time.dt=1e-3"])
    assert done.returncode == 2
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1 and lines[0].startswith("pmpm: error: time.dt: 0.001 exceeds "
                                                   "the stable step at the start")


def test_a_fixed_step_the_stable_step_falls_below_stops_the_run(tmp_path):
    """The bar pushed sideways by a huge gravity: its speed adds to the wave speed, so
    the stable step shrinks below a fixed step just under the starting one."""
    refused = pmpm([BAR, "--out", tmp_path / "a", "--quiet", "--set", "time.dt=1e-3"])
    stable = float(re.search(r"at the start, ([0-9.e+-]+) ", refused.stderr).group(1))
    done = pmpm([BAR, "--out", tmp_path / "b", "--quiet", "--set",
                 f"time.dt={0.97 * stable!r}", "--set", "gravity=[1e6, 0, 0]"])
    assert done.returncode == 1
    line = pmpm_lines(done.stderr)[0]
    assert int(re.match(r"pmpm: run stopped: step (\d+) ", line).group(1)) > 1   # later
    assert "the fixed step time.dt = " in line and "exceeds the stable step" in line


def test_dt_and_dt_max_together_are_refused(tmp_path):
    case = tmp_path / "case.yaml"
    case.write_text(open(BAR).read())
    with pytest.raises(CaseError, match=r"time\.dt: give time\.dt .* not both"):
        load_case(str(case), overrides=["time.dt=1e-5", "time.dt_max=1e-4"])


OGIVE = os.path.join(ROOT, "runs", "ogive_plate_fem.yaml")
COARSE_OGIVE = ["params.cell=4", "params.plate_element=4", "params.rod_element=5.7"]


def test_with_a_fixed_step_elements_convert_before_it_outruns_them():
    """Converting bodies take the fixed step as a floor: an element whose stable step
    falls below time.dt becomes particles (pmpm.solver.conversion.floor_rates) instead
    of stopping the run. Without a fixed step only the cell's floor holds."""
    from types import SimpleNamespace
    from pmpm.solver.conversion import floor_rates
    for dt, expected in ((None, [2.0, 0.0, 0.0]), (1.0, [1.0, 1.0, 0.0]),
                         (0.25, [2.0, 4.0, 0.0])):
        rules = SimpleNamespace(divisions=np.array([2, 2, 0]),   # the third: no conversion
                                step_ratio=np.array([0.5, 0.0, 0.5]), fixed_dt=dt)
        assert floor_rates(rules, np.ones(3)).tolist() == expected
        assert floor_rates(rules, np.ones(3), fixed=False).tolist() == [2.0, 0.0, 0.0]


def test_the_coarse_perforation_runs_at_a_fixed_step_its_crushed_elements_outrun(tmp_path):
    """The 4 mm perforation at time.dt = 2e-4 ms: a crushed plate element's stable step
    fell below it at step 92 (t = 18 us) and the run stopped; now such elements convert
    and the run takes every step of 2e-4 ms to 25 us, on 2 ranks as on 1."""
    args = [a for o in COARSE_OGIVE + ["time.dt=2e-4", "time.end=0.025", "output.frames=1",
                                       "output.history_every=1"] for a in ("--set", o)]
    histories = []
    for ranks in (1, 2):
        out = tmp_path / f"out{ranks}"
        run_ok([OGIVE, "--out", out, "--quiet"] + args, ranks=ranks)
        header, rows = read_history(out)
        assert rows[-1, header.index("step")] == 125
        assert np.allclose(rows[1:, header.index("dt")], 2e-4, rtol=1e-9, atol=0)
        with open(out / "summary.json", encoding="utf-8") as f:
            summary = json.load(f)
        assert summary["n_particles"]["final"] > 0        # elements converted
        assert summary["element_step_limit"]["stable_step"] >= 2e-4 * (1 - 1e-9)
        histories.append(rows)
    scale = np.maximum(np.abs(histories[0]).max(axis=0), 1.0)
    assert np.all(np.abs(histories[1] - histories[0]) <= 1e-10 * scale)
