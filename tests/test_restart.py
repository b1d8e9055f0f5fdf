"""--restart: a run continued from a checkpoint ends where the uninterrupted one does, with
the same time steps, and leaves history.csv and particles.h5 as one run would have.

cli_bar.yaml has a frame at t = 0.0025, half its end time, so a run cut there with
``--set time.end=0.0025`` takes the same steps as the full run up to there; it leaves a
checkpoint of its final state, from which ``--restart --set time.end=0.005`` goes on.
"""
import os
import shutil

import numpy as np
import pytest

from clihelp import (BAR, BAR_HALF_END, assert_same_state, frame, frame_list, pmpm,
                     pmpm_lines, read_history, run_ok)
from pmpm.io import latest_checkpoint
from pmpm.io.summary import read_summary
from pmpm.io.checkpoint import list_checkpoints

END = "time.end=0.005"


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """The full run of cli_bar.yaml on 1 rank (48 steps, checkpoints every 10)."""
    out = tmp_path_factory.mktemp("restart") / "full"
    run_ok([BAR, "--out", out, "--quiet"])
    return out


def cut_run(out, ranks=1):
    run_ok([BAR, "--out", out, "--quiet", "--set", f"time.end={BAR_HALF_END}"], ranks)


@pytest.fixture(scope="module")
def cut_on_one_rank(tmp_path_factory):
    """A run cut at t = BAR_HALF_END on 1 rank; the tests restart copies of it."""
    out = tmp_path_factory.mktemp("restart") / "cut"
    cut_run(out)
    return out


def restart(out, ranks=1, end=END):
    return run_ok([BAR, "--out", out, "--quiet", "--restart", "--set", end], ranks)


def assert_continues(out, full, rtol):
    """``out`` holds the same final state, history and frames as the run in ``full``."""
    assert_same_state(frame(full), frame(out), rtol)
    header, rows = read_history(out)
    full_header, full_rows = read_history(full)
    assert header == full_header
    steps = rows[:, 0]
    assert len(set(steps)) == len(steps), "repeated steps in history.csv"
    assert (np.diff(steps) > 0).all() and (np.diff(rows[:, 1]) > 0).all()
    assert set(full_rows[:, 0]) <= set(steps)
    same = np.isin(steps, full_rows[:, 0])
    # the time-step sequence after the restart is the uninterrupted one
    np.testing.assert_allclose(rows[same, :3], full_rows[:, :3], rtol=rtol, atol=0)
    np.testing.assert_allclose(rows[same, 3:], full_rows[:, 3:], rtol=1e-9, atol=1e-9)
    frames = frame_list(out)
    times = [t for t, _ in frames]
    assert times == sorted(set(times)), f"frames out of order or repeated: {frames}"
    assert frames[0] == (0.0, 0)
    assert frames[-1][1] == frame_list(full)[-1][1] == 48


def test_restart_after_a_cut_run_matches_the_uninterrupted_run(tmp_path, uninterrupted,
                                                               cut_on_one_rank):
    out = tmp_path / "out"
    shutil.copytree(cut_on_one_rank, out)
    assert latest_checkpoint(out).endswith("checkpoint_000024.h5"), os.listdir(out)
    restart(out)
    assert_continues(out, uninterrupted, rtol=1e-12)
    assert frame_list(out) == frame_list(uninterrupted)
    summary, full = read_summary(out), read_summary(uninterrupted)
    for key in ("n_steps", "t_end", "n_particles", "energy", "bodies"):
        assert summary[key] == full[key], key


def test_restart_after_a_crash_matches_the_uninterrupted_run(tmp_path, uninterrupted):
    """A run killed after step 40: its checkpoint of step 48 is gone, and history.csv and
    particles.h5 hold rows and a frame written after the checkpoint of step 40 (a copy
    of the uninterrupted run's directory is what such a run leaves)."""
    out = tmp_path / "out"
    shutil.copytree(uninterrupted, out)
    assert [step for step, _ in list_checkpoints(out)] == [40, 48]
    os.remove(latest_checkpoint(out))
    (out / "summary.json").unlink()
    restart(out)
    assert_continues(out, uninterrupted, rtol=1e-12)
    assert frame_list(out) == frame_list(uninterrupted)
    assert [step for step, _ in list_checkpoints(out)][-1] == 48


@pytest.mark.parametrize("before, after", [(1, 2), (2, 1)])
def test_restart_on_another_number_of_ranks(tmp_path, uninterrupted, cut_on_one_rank,
                                            before, after):
    out = tmp_path / "out"
    if before == 1:
        shutil.copytree(cut_on_one_rank, out)
    else:
        cut_run(out, ranks=before)
    restart(out, ranks=after)
    assert_continues(out, uninterrupted, rtol=1e-12)
    summary = read_summary(out)
    assert summary["ranks"] == after and summary["n_steps"] == 48


def test_restart_of_a_finished_run_changes_nothing(tmp_path, uninterrupted):
    out = tmp_path / "out"
    shutil.copytree(uninterrupted, out)
    before = read_history(out)[1]
    restart(out)
    assert np.array_equal(read_history(out)[1], before)
    assert frame_list(out) == frame_list(uninterrupted)
    assert_same_state(frame(uninterrupted), frame(out), 0.0)


def test_a_restart_with_its_frame_file_gone_starts_a_new_one(tmp_path, cut_on_one_rank):
    """particles.h5 deleted (to save space, say) before --restart: the run goes on and
    warns, and the new file holds the frames from the checkpoint on (it stopped with
    h5py's bare 'no such file or directory' before)."""
    out = tmp_path / "out"
    shutil.copytree(cut_on_one_rank, out)
    (out / "particles.h5").unlink()
    done = run_ok([BAR, "--out", out, "--restart", "--quiet", "--set", END])
    assert any("particles.h5 is missing" in line for line in pmpm_lines(done.stderr))
    times = [t for t, _ in frame_list(out)]
    assert times and min(times) > float(BAR_HALF_END) * (1 - 1e-9)


def test_restart_needs_a_checkpoint(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    done = pmpm([BAR, "--out", out, "--restart"])
    assert done.returncode == 2
    assert pmpm_lines(done.stderr) == [f"pmpm: error: --restart: no checkpoint in '{out}'"]


def test_restart_with_an_earlier_end_time_is_refused(tmp_path, cut_on_one_rank):
    out = tmp_path / "out"
    shutil.copytree(cut_on_one_rank, out)
    done = pmpm([BAR, "--out", out, "--restart", "--set", "time.end=0.001",
                 "--set", "output.times=[]"])
    assert done.returncode == 2, done.stderr
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1 and lines[0].startswith("pmpm: error: time.end: 0.001 is before"), lines


#: a run long enough (about 6,500 steps, some 6 s warm) to be signalled in its loop:
#: mpirun takes about 2 s to pass a signal on, and 1.5 periods (1,200 steps) could end first.
#: One frame, at the end, so that no frame time clips a step before the end: a run with
#: another end time takes the same steps up to there.
LONG = [os.path.join(os.path.dirname(BAR), "..", "..", "runs", "vibrating_bar.yaml"),
        "--quiet", "--set", "params.periods=8", "--set", "output.energy_warning=0",
        "--set", "output.frames=1"]
#: how far (ms, some 180 steps) the restart and the uninterrupted run it is compared with
#: go past the signalled run's checkpoint; neither need run LONG's 8 periods
PAST_CHECKPOINT = 0.02


def signal_run(out, ranks, target):
    """Start LONG into ``out`` on ``ranks``, send SIGTERM to ``target`` ("mpirun" or
    "ranks") once it has written a few history rows; returns the CompletedProcess."""
    import signal
    import subprocess
    import time
    from clihelp import ENV, ROOT, command
    env = dict(os.environ, **ENV, PYTHONPATH=ROOT)
    run = subprocess.Popen(command([*LONG[:1], "--out", out, *LONG[1:]], ranks),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           env=env, cwd=ROOT)
    history = out / "history.csv"
    stop = time.monotonic() + 240
    while run.poll() is None and time.monotonic() < stop and not (
            history.exists() and len(history.read_text().splitlines()) >= 6):
        time.sleep(0.05)
    pids = [run.pid]
    if target == "ranks" and ranks > 1:
        children = subprocess.run(["ps", "-o", "pid=", "--ppid", str(run.pid)],
                                  capture_output=True, text=True).stdout.split()
        pids = [int(pid) for pid in children]
    for pid in pids:
        os.kill(pid, signal.SIGTERM)
    stdout, stderr = run.communicate(timeout=120)
    return subprocess.CompletedProcess(run.args, run.returncode, stdout, stderr)


def checkpoint_time(out):
    """The simulated time of the newest checkpoint in ``out``."""
    import json
    import h5py
    with h5py.File(latest_checkpoint(str(out)), "r") as f:
        return json.loads(f.attrs["scalars"])["time"]


@pytest.mark.parametrize("ranks, target", [(1, "ranks"), (2, "mpirun"), (2, "ranks")])
def test_sigterm_leaves_a_checkpoint_and_the_restart_ends_as_the_uninterrupted_run(
        tmp_path, ranks, target):
    """Issue 27: a scheduler's SIGTERM (to mpirun, or to each rank as srun does) makes
    every rank finish its step, write a checkpoint and stop with one line; the ranks
    exit 3 (mpirun, signalled itself, reports 1); --restart ends where the run that
    was not interrupted does (both end PAST_CHECKPOINT after the checkpoint: a restart
    may move the end time, and LONG's steps do not depend on it)."""
    out = tmp_path / "out"
    done = signal_run(out, ranks, target)
    lines = pmpm_lines(done.stderr)
    assert len(lines) == 1 and lines[0].startswith("pmpm: interrupted by SIGTERM after "
                                                   "step "), done.stderr
    assert done.returncode == (1 if target == "mpirun" else 3), done.stderr
    step = int(lines[0].split("after step ")[1].split()[0])
    assert latest_checkpoint(str(out)).endswith(f"checkpoint_{step:06d}.h5")
    assert not (out / "summary.json").exists() and not (out / "pmpm.lock").exists()
    end = f"time.end={checkpoint_time(out) + PAST_CHECKPOINT!r}"
    full = tmp_path / "full"
    run_ok([*LONG[:1], "--out", full, *LONG[1:], "--set", end], ranks)
    assert 0 < step < read_summary(str(full))["n_steps"]
    run_ok([*LONG[:1], "--out", out, *LONG[1:], "--restart", "--set", end], ranks)
    assert_same_state(frame(full), frame(out), 1e-12)
    assert read_summary(str(out))["n_steps"] == read_summary(str(full))["n_steps"]
