"""Start-up times (issue 25): from process start to the first step with a warm kernel
cache, and how fast ``--help`` and bad input exit.

For each small case on 1 and 2 ranks, each run gives (medians over ``--repeat``, the
runs of all cases interleaved, so that each spreads over the same stretch of a loaded
machine):

- ``startup_wall`` / ``startup_cpu``: summary.json's ``startup_s``, from the process's
  start (the kernel's start time, 10 ms resolution) to its first step, the slowest rank's;
  CPU is one rank's own (user + system), the figure a loaded machine does not blur;
- ``startup_unqueued``: that wall time less the time the rank's main thread waited for a
  core (/proc/self/schedstat): about what an idle machine would take (MPI_Init's waits
  stay in it, other processes' load does not);
- ``launch_wall``: from the launch (``python`` or ``mpirun``) to the first step (rank 0's
  clock at its first step against this script's clock at the launch);
- ``total_cpu``: the CPU of the whole command, launcher and every rank, to its exit.

The quick exits (``--help``, a missing case file, a misspelt key, an unknown material, a
YAML syntax error) give the wall and CPU time of the whole command and check that it
exits 2 (0 for --help) naming the key. The floors: a bare ``python``, ``import numpy``,
``from mpi4py import MPI`` on 1 and 2 ranks (MPI_Init), as Open MPI starts by default
and with the choices pmpm makes (pmpm.comm.launch).

Usage: .venv/bin/python scripts/startup.py [--repeat 5] [--ranks 1 2] [--only NAME ...]
                                           [--out results/startup]
                                           [--tree [TAG=]CHECKOUT ...]
Run it once first (or scripts/setup.sh) so that the kernels are cached: every run counts
in the medians, a first one that compiles too. Writes results/startup/startup.{json,md}.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

from _common import ENV, PYTHON, ROOT, save_json, write_lines
from pmpm.comm.launch import ONE_MACHINE, SINGLETON

TAYLOR = ("runs/taylor_bar.yaml", ["params.cell=1.52", "params.refined=12.16",
                                   "time.end=0.001", "output.frames=1"])
CASES = {
    # the seed case pins the papers' hats (linear)
    "taylor_linear": TAYLOR,
    # pmpm's default shape functions
    "taylor_gimp": (TAYLOR[0], TAYLOR[1] + ["grid.shape_functions=gimp"]),
    # one FEM body of 1,000 hexahedra on a slip wall
    "fem_block": ("runs/fem_block.yaml", ["params.edge=10", "params.element=1.0",
                                          "time.end=0.0005", "output.frames=1"]),
}

YAML_SYNTAX_ERROR = "title: broken\ngrid: {min: [0, 0, 0]\n"

#: name -> (pmpm's arguments, the exit status it must give, text its stderr or stdout
#: must hold)
QUICK = {
    "help": (["--help"], 0, "usage:"),
    "missing_file": (["runs/no_such_case.yaml"], 2, "no_such_case.yaml"),
    "bad_key": ([TAYLOR[0], "--set", "time.endd=1"], 2, "time.endd"),
    "bad_material": ([TAYLOR[0], "--set", "bodies[0].material=coper"], 2, "coper"),
    "yaml_syntax": (["{syntax}"], 2, "line"),
}

FLOORS = {
    "python": ["-c", "pass"],
    "import_numpy": ["-c", "import numpy"],
    "import_mpi4py_MPI": ["-c", "from mpi4py import MPI"],
    # with the Open MPI choices pmpm makes (pmpm.comm.launch: SINGLETON or ONE_MACHINE)
    "import_mpi4py_MPI_quick": ["-c", "from mpi4py import MPI"],
}


def python():
    return PYTHON if os.path.exists(PYTHON) else sys.executable


def launch(args, ranks):
    """The command line of ``python ARGS`` on ``ranks`` ranks."""
    cmd = [python()] + list(args)
    return ["mpirun", "-n", str(ranks), "--oversubscribe"] + cmd if ranks > 1 else cmd


def timed(cmd, tree=ROOT, settings=None):
    """Run ``cmd`` in the source tree ``tree`` (its pmpm); returns (exit status, wall
    seconds, CPU seconds of the command and every process it waited for, output text,
    the launch's clock time). ``settings``: environment variables to add."""
    at = time.time()
    started = time.perf_counter()
    with tempfile.TemporaryFile() as sink:
        env = dict(ENV, PYTHONPATH=tree, **(settings or {}))
        process = subprocess.Popen(cmd, env=env, cwd=tree, stdout=sink,
                                   stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(process.pid, 0)
        wall = time.perf_counter() - started
        process.returncode = os.waitstatus_to_exitcode(status)
        sink.seek(0)
        text = sink.read().decode(errors="replace")
    return process.returncode, wall, usage.ru_utime + usage.ru_stime, text, at


def run_case(name, ranks, out, tree=ROOT):
    case, sets = CASES[name]
    args = ["-m", "pmpm", case, "--out", out, "--force", "--quiet"]
    for item in sets:
        args += ["--set", item]
    status, wall, cpu, text, at = timed(launch(args, ranks), tree)
    if status != 0:
        raise SystemExit(f"{name} on {ranks} rank(s) failed ({status}):\n{text}")
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    startup = summary["startup_s"]
    return {"startup_wall": startup["wall"], "startup_cpu": startup["cpu"],
            "startup_unqueued": startup["wall_less_queued"],
            "launch_wall": startup["at"] - at, "total_wall": wall, "total_cpu": cpu,
            "compile_s": summary["compile_s"], "first_step_s": summary["first_step_s"]}


def run_quick(name, syntax_file, tree=ROOT):
    args, expected, needle = QUICK[name]
    args = [syntax_file if a == "{syntax}" else a for a in args]
    status, wall, cpu, text, _ = timed(launch(["-m", "pmpm"] + args, 1), tree)
    if status != expected or needle not in text:
        raise SystemExit(f"{name}: exit {status} (expected {expected}), output lacks "
                         f"{needle!r}:\n{text}")
    return {"wall": wall, "cpu": cpu}


def run_floor(name, ranks):
    settings = (ONE_MACHINE if ranks > 1 else SINGLETON) if name.endswith("_quick") else {}
    status, wall, cpu, text, _ = timed(launch(FLOORS[name], ranks), settings=settings)
    if status != 0:
        raise SystemExit(f"{name} failed:\n{text}")
    return {"wall": wall, "cpu": cpu}


def medians(runs):
    return {key: statistics.median(run[key] for run in runs) for key in runs[0]}


def measure(options, syntax_file):
    """Every measurement ``options.repeat`` times for each tree, interleaved (each
    repeat runs every job of every tree once); {label: [runs]}."""
    wanted = options.only
    jobs = []
    for tag, tree in options.trees:
        prefix = f"{tag}: " if len(options.trees) > 1 else ""
        jobs += [(f"{prefix}{name} {ranks}r", lambda n=name, r=ranks, t=tree, p=tag:
                  run_case(n, r, os.path.join(options.out, f"{p}_{n}_{r}"), t))
                 for ranks in options.ranks for name in CASES
                 if not wanted or name in wanted]
        jobs += [(f"{prefix}{name}", lambda n=name, t=tree: run_quick(n, syntax_file, t))
                 for name in QUICK if not wanted or name in wanted or "quick" in wanted]
    jobs += [(f"floor {name} {ranks}r", lambda n=name, r=ranks: run_floor(n, r))
             for name in FLOORS for ranks in options.ranks
             if not wanted or "floors" in wanted]
    runs = {label: [] for label, _ in jobs}
    for k in range(options.repeat):
        for label, job in jobs:
            runs[label].append(job())
            print(f"[{k + 1}/{options.repeat}] {label}: "
                  + ", ".join(f"{key} {value:.3f}" for key, value in runs[label][-1].items()),
                  flush=True)
    return runs


def table(runs):
    lines = ["| what | ranks | start to 1st step, wall | wall less queued | CPU (a rank) |"
             " launch to 1st step | whole command CPU | load of kernels |",
             "|---|---|---|---|---|---|---|---|"]
    for label, rows in runs.items():
        m = medians(rows)
        if "startup_cpu" in m:
            name, ranks = label.rsplit(" ", 1)
            lines.append(f"| {name} | {ranks[:-1]} | {m['startup_wall']:.2f} s | "
                         f"{m['startup_unqueued']:.2f} s | "
                         f"{m['startup_cpu']:.2f} s | {m['launch_wall']:.2f} s | "
                         f"{m['total_cpu']:.2f} s | {m['compile_s']:.2f} s |")
    lines += ["", "| quick exit or floor | wall | CPU |", "|---|---|---|"]
    for label, rows in runs.items():
        m = medians(rows)
        if "wall" in m:
            lines.append(f"| {label} | {m['wall']:.3f} s | {m['cpu']:.3f} s |")
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--only", nargs="+", default=[],
                        help="case or quick-exit names, 'quick' or 'floors'")
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "startup"))
    parser.add_argument("--tree", nargs="+", default=[ROOT], metavar="[TAG=]PATH",
                        help="run the pmpm of these source trees, interleaved (default: "
                             "this checkout), e.g. before=/tmp/base after=.")
    options = parser.parse_args()
    options.trees = [(item.partition("=")[0], os.path.abspath(item.partition("=")[2]))
                     if "=" in item else (os.path.basename(os.path.abspath(item)),
                                          os.path.abspath(item)) for item in options.tree]
    with tempfile.NamedTemporaryFile("w", suffix=".yaml", delete=False) as broken:
        broken.write(YAML_SYNTAX_ERROR)
    try:
        runs = measure(options, broken.name)
    finally:
        os.unlink(broken.name)
    save_json(os.path.join(options.out, "startup.json"),
              {"runs": runs, "medians": {label: medians(rows) for label, rows in runs.items()},
               "repeat": options.repeat, "command": " ".join(sys.argv),
               "trees": dict(options.trees)})
    write_lines(os.path.join(options.out, "startup.md"), table(runs), echo=True)


if __name__ == "__main__":
    main()
