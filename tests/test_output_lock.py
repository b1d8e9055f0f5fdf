"""Issue 27: a run locks its output directory for its whole life (``DIR/pmpm.lock``,
created atomically by rank 0 before anything is written, removed at exit), so that a
second run into the same directory is refused (exit 2) instead of corrupting the first
one's files; a stale lock of a dead run is named and replaced; a directory that cannot
be written is refused before the set-up."""
import os
import pathlib
import shutil
import socket
import subprocess
import sys
import tempfile
import time

import h5py
import pytest

from clihelp import BAR, ENV, ROOT, command, pmpm, pmpm_lines

LOCK = "pmpm.lock"


def start(args, ranks=1):
    env = dict(os.environ, **ENV)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [ROOT, env.get("PYTHONPATH")]))
    return subprocess.Popen(command(args, ranks), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)


def wait_for(path, first, limit=60.0):
    """Wait until ``path`` exists (or the first run ended, or ``limit`` s passed)."""
    stop = time.monotonic() + limit
    while not os.path.exists(path) and first.poll() is None and time.monotonic() < stop:
        time.sleep(0.02)


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_second_run_into_a_running_runs_directory_is_refused(tmp_path, ranks):
    out = tmp_path / "out"
    # 4700 steps (several seconds): the second run's start-up (imports, the case) must
    # fall inside the first one's life even on a loaded machine; 48 steps did not.
    first = start([BAR, "--out", out, "--quiet", "--set", "time.end=0.5",
                   "--set", "output.checkpoint_every=1000"], ranks)
    wait_for(out / LOCK, first)
    second = pmpm([BAR, "--out", out, "--force", "--quiet"], ranks)
    still_running = first.poll() is None
    stdout, stderr = first.communicate(timeout=300)
    assert second.returncode == 2, (second.stderr, f"first run still running: {still_running}")
    lines = pmpm_lines(second.stderr)
    assert len(lines) == 1 and "is in use by another pmpm run" in lines[0], lines
    assert f"on {socket.gethostname()}" in lines[0] and LOCK in lines[0]
    assert first.returncode == 0, stderr
    for name in ("particles.h5", "history.csv", "summary.json"):
        assert (out / name).exists()
    with h5py.File(out / "particles.h5", "r") as f:
        assert len(f["frames"]) >= 2
    assert not (out / LOCK).exists(), "the lock outlived its run"


def dead_pid():
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_a_stale_lock_of_a_dead_run_is_named_and_replaced(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    pid = dead_pid()
    (out / LOCK).write_text(f"pid {pid} on {socket.gethostname()} since 2026-01-01 "
                            "00:00:00\n")
    done = pmpm([BAR, "--out", out, "--quiet", "--set", "time.end=0.0025"], timeout=300)
    assert done.returncode == 0, done.stderr
    warnings = pmpm_lines(done.stderr)
    assert len(warnings) == 1 and "stale lock" in warnings[0] and f"pid {pid}" in warnings[0]
    assert (out / "summary.json").exists() and not (out / LOCK).exists()


def test_a_lock_held_by_a_live_process_refuses_even_a_restart(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    holder = f"pid {os.getpid()} on {socket.gethostname()} since 2026-01-01 00:00:00"
    (out / LOCK).write_text(holder + "\n")
    for extra in ([], ["--restart"], ["--force"]):
        done = pmpm([BAR, "--out", out, "--quiet", *extra])
        assert done.returncode == 2
        assert pmpm_lines(done.stderr) == [
            f"pmpm: error: --out: '{out}' is in use by another pmpm run ({holder}; lock "
            f"file {out / LOCK}); wait for it to end, choose another --out, or delete the "
            f"lock if that run is dead"]
    assert os.listdir(out) == [LOCK]


@pytest.mark.skipif(os.geteuid() != 0 and not os.access("/", os.W_OK), reason="")
def test_an_output_directory_that_cannot_be_written_is_refused_before_the_set_up():
    """Run as an unprivileged user (root writes anywhere) into a directory it may read
    but not write (under /tmp: pytest's tmp_path is closed to other users)."""
    tmp_path = pathlib.Path(tempfile.mkdtemp(prefix="pmpm_unwritable_"))
    out = tmp_path / "out"
    out.mkdir()
    os.chmod(tmp_path, 0o777)
    os.chmod(out, 0o555)
    args = [BAR, "--out", out, "--quiet"]
    env = dict(os.environ, **ENV, PYTHONPATH=ROOT, NUMBA_CACHE_DIR=str(tmp_path / "nc"))
    cmd = command(args)
    if os.geteuid() == 0:
        cmd = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", *cmd]
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=str(tmp_path),
                          timeout=120)
    assert done.returncode == 2, done.stderr
    assert pmpm_lines(done.stderr) == [
        f"pmpm: error: --out: cannot write in output directory '{out}': Permission denied"]
    assert os.listdir(out) == []
    shutil.rmtree(tmp_path)
