"""A run that blows up stops every rank with exit status 1 and one message naming the step,
the particle and the body; it does not hang, and its files stay readable.

cli_fault.yaml fails for certain: its Mie-Grueneisen slope s = 1001 limits compression to
mu = 0.001, which the impact exceeds in its first steps (the EOS then gives NaN).
"""
import json
import re

import h5py
import numpy as np
import pytest

from clihelp import BAR, FAULT, frame_list, pmpm, pmpm_lines, read_history
from pmpm.io import latest_checkpoint
from pmpm.io.checkpoint import list_checkpoints

MESSAGE = re.compile(
    r"^pmpm: run stopped: step (\d+) \(t = \S+ to \S+\): particle id (\d+) of body 'bar': "
    r"constitutive update failed .*; last checkpoint: (\S+) \(step (\d+)\)$")


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_fault_stops_every_rank_with_one_message(tmp_path, ranks):
    out = tmp_path / "out"
    done = pmpm([FAULT, "--out", out, "--quiet"], ranks, timeout=60)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1, lines
    match = MESSAGE.match(lines[0])
    assert match, lines[0]
    step, particle, checkpoint, checkpoint_step = match.groups()
    assert 20 < int(step) < 48 and int(particle) >= 0
    assert not (out / "summary.json").exists()

    # the last checkpoint is the one named, of a step before the fault, and readable
    assert latest_checkpoint(out) == checkpoint
    assert int(checkpoint_step) == list_checkpoints(out)[-1][0] < int(step)
    with h5py.File(checkpoint, "r") as f:
        assert int(f.attrs["n_total"]) == 624
        scalars = json.loads(f.attrs["scalars"])
        columns = {name: data[:] for name, data in f["columns"].items()}
    assert scalars["step"] == int(checkpoint_step)
    assert np.isfinite(columns["x"]).all() and np.isfinite(columns["stress"]).all()
    assert sorted(columns["id"]) == list(range(624))

    # particles.h5 was closed properly and history.csv holds the steps before the fault
    assert frame_list(out)[0] == (0.0, 0)
    steps = read_history(out)[1][:, 0]
    assert steps[-1] < int(step) and len(set(steps)) == len(steps)


def test_restart_from_the_checkpoint_before_a_fault_meets_it_again(tmp_path):
    out = tmp_path / "out"
    first = pmpm([FAULT, "--out", out, "--quiet"], timeout=60)
    again = pmpm([FAULT, "--out", out, "--quiet", "--restart"], ranks=2, timeout=60)
    assert (first.returncode, again.returncode) == (1, 1), again.stderr
    step = [MESSAGE.match(pmpm_lines(d.stderr)[0]).group(1) for d in (first, again)]
    assert step[0] == step[1]


def test_energies_that_overflow_stop_the_run_with_one_line(tmp_path):
    """Found by tests/test_fuzz.py: a density of 1e308 made the mass and the kinetic
    energy infinite and the run ended in a traceback from the summary's contract check.
    (The unit checks refuse such a density at input; ``units: other`` lets it through to
    the run, whose own guard is what this tests.)"""
    done = pmpm([BAR, "--quiet", "--out", tmp_path / "o", "--set", "units=other",
                 "--set", "materials.copper.density=1e308"])
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    assert any("the energies are not finite" in line for line in pmpm_lines(done.stderr))
