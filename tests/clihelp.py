"""Helpers for the command-line tests: run ``python -m pmpm`` on 1 or 2 ranks in a
subprocess, and read back what a run wrote."""
import csv
import os
import subprocess
import sys

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CASES = os.path.join(ROOT, "tests", "cases")
BAR = os.path.join(CASES, "cli_bar.yaml")      # 624 particles, 48 steps to t = 0.005
FAULT = os.path.join(CASES, "cli_fault.yaml")  # fails at step 25 (EOS limit compression)
BAR_HALF_END = 0.0025                           # a frame time of cli_bar.yaml
ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
       "OMPI_MCA_rmaps_base_oversubscribe": "1", "NUMBA_NUM_THREADS": "1",
       "OMP_NUM_THREADS": "1"}


def command(args, ranks=1):
    cmd = [sys.executable, "-m", "pmpm", *map(str, args)]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe", *cmd]
    return cmd


def pmpm(args, ranks=1, cwd=None, timeout=60):
    """Run ``python -m pmpm ARGS`` (under mpirun when ranks > 1); returns the
    CompletedProcess with text stdout and stderr. A run that hangs fails the test."""
    env = dict(os.environ, **ENV)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [ROOT, env.get("PYTHONPATH")]))
    return subprocess.run(command(args, ranks), capture_output=True, text=True, env=env,
                          cwd=cwd or ROOT, timeout=timeout)


def run_ok(args, ranks=1, cwd=None, timeout=300):
    """A run that must succeed. Its first run on a fresh clone compiles the kernels it
    needs (about a minute on a busy 2-core machine), so the hang guard is longer."""
    done = pmpm(args, ranks, cwd, timeout)
    assert done.returncode == 0, f"pmpm {args} on {ranks} ranks failed:\n{done.stderr}"
    return done


def pmpm_lines(stderr):
    """pmpm's own lines on stderr (mpirun adds its notices about the exit status)."""
    return [line for line in stderr.splitlines() if line.startswith("pmpm:")]


def read_history(out):
    """history.csv as (header, rows as float arrays)."""
    with open(os.path.join(out, "history.csv"), newline="", encoding="utf-8") as handle:
        table = list(csv.reader(handle))
    return table[0], np.array([[float(v) for v in row] for row in table[1:]])


def frame_list(out):
    """(time, step) of every frame of particles.h5, in index order."""
    with h5py.File(os.path.join(out, "particles.h5"), "r") as f:
        names = sorted(f["frames"], key=int)
        return [(float(f["frames"][n].attrs["time"]), int(f["frames"][n].attrs["step"]))
                for n in names]


def frame(out, index=-1):
    """Columns of one frame of particles.h5, rows sorted by particle id."""
    with h5py.File(os.path.join(out, "particles.h5"), "r") as f:
        names = sorted(f["frames"], key=int)
        group = f["frames"][names[index]]
        order = np.argsort(group["id"][:])
        return {name: group[name][:][order] for name in group}


def assert_same_state(a, b, rtol):
    """Every column equal to ``rtol`` relative to the column's largest magnitude."""
    assert sorted(a) == sorted(b)
    assert np.array_equal(a["id"], b["id"])
    for name in a:
        x, y = a[name].astype(np.float64), b[name].astype(np.float64)
        scale = max(np.abs(x).max(), 1e-300)
        err = np.abs(x - y).max() / scale
        assert err <= rtol, f"column {name}: relative difference {err:.3e} > {rtol:g}"
