"""What weighing the elements in the slabs' balance does to a 2-rank run (issue 24).

The case: tests/cases/striker_on_fem_bar.yaml widened to 5 mm (10 x 10 cells): a
particle striker (16,000 particles, hats) on the left hits an FEM bar (8,000 hexahedra,
stiffness hourglass control) on the right, slabs along x, so that elements and
particles sit apart along the slab axis. It runs on 2 ranks with the code of two
checkouts, interleaved, ``--repeat`` times: ``--before`` (elements counted 1 each, as
before issue 24) and this one. For each run: the stepping wall time per step, each
rank's busy CPU time per step outside communication (scripts/busy_time.py: on a shared
machine the wall time follows the other jobs' load, the busy time much less), the slab
plane, and from the final frames the imbalance of each rank's work, counted plainly
(particles + elements) and weighted (elements by pmpm.solver.work_weights).

Writes results/rebalance_effect/effect.{json,md}.

Usage: .venv/bin/python scripts/rebalance_effect.py --before /path/to/old/checkout
                                                     [--repeat 3]
"""
import argparse
import json
import os
import statistics
import subprocess

import h5py
import numpy as np

from _common import ENV, ROOT, save_json, write_lines

CASE = "tests/cases/striker_on_fem_bar.yaml"
SETS = ["params.width=5.0", "time.end=0.024", "decomposition.axis=x", "output.frames=1"]


def run(tree, out):
    """Run the case on 2 ranks with the code in ``tree`` under scripts/busy_time.py;
    returns summary.json with each rank's busy CPU seconds under ``busy_cpu_s``."""
    python = os.path.join(tree, ".venv", "bin", "python")
    busy = os.path.join(out + "_busy.json")
    cmd = ["mpirun", "-n", "2", "--oversubscribe", python,
           os.path.join(ROOT, "scripts", "busy_time.py"), tree, busy,
           os.path.join(tree, CASE), "--out", out, "--force", "--quiet"]
    for item in SETS:
        cmd += ["--set", item]
    print("+", " ".join(cmd), flush=True)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    subprocess.run(cmd, check=True, env=ENV, cwd=tree)
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    with open(busy, encoding="utf-8") as f:
        summary["busy_cpu_s"] = [r["busy_cpu_s"] for r in json.load(f)["ranks"]]
    return summary


def final_positions(out):
    """Particle positions and element centroids of the last frame."""
    with h5py.File(os.path.join(out, "particles.h5"), "r") as f:
        frames = f["frames"]
        x = frames[sorted(frames, key=lambda k: frames[k].attrs["time"])[-1]]["x"][:]
    with h5py.File(os.path.join(out, "elements.h5"), "r") as f:
        frames = f["frames"]
        c = frames[sorted(frames, key=lambda k: frames[k].attrs["time"])[-1]]["centroid"][:]
    return x, c


def imbalances(bounds, out, weight):
    """(plain, weighted) max/mean - 1 of the slabs' work at the end (``bounds``: the
    final slab planes, in cells)."""
    x, c = final_positions(out)
    bounds = np.asarray(bounds)
    h = 0.5                                          # the case's cell (mm); grid min x 0
    result = []
    for w in (1.0, weight):
        cells = np.concatenate([np.floor(x[:, 0] / h), np.floor(c[:, 0] / h)]).astype(int)
        weights = np.concatenate([np.ones(len(x)), np.full(len(c), w)])
        per_rank = np.array([weights[(cells >= bounds[r]) & (cells < bounds[r + 1])].sum()
                             for r in range(len(bounds) - 1)])
        result.append(float(per_rank.max() / per_rank.mean() - 1))
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="checkout without element weights")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "rebalance_effect"))
    args = parser.parse_args()
    trees = {"before": os.path.abspath(args.before), "weighted": ROOT}
    rows = []
    weight = None
    for repeat in range(args.repeat):
        for name, tree in trees.items():
            out = os.path.join(args.out, f"{name}_{repeat}")
            s = run(tree, out)
            weight = s.get("element_weights", {}).get("bar", weight)
            rows.append({"code": name, "repeat": repeat,
                         "step_ms": 1e3 * s["step_wall_s"] / s["n_steps"],
                         "steps": s["n_steps"], "bounds": s["slabs"]["bounds"],
                         "elements_per_rank": s["elements_per_rank"], "out": out,
                         "busy_ms": [1e3 * b / s["n_steps"] for b in s["busy_cpu_s"]]})
            print(rows[-1], flush=True)
    for r in rows:
        r["plain"], r["weighted"] = imbalances(r["bounds"], r["out"], weight)
    medians = {name: statistics.median(r["step_ms"] for r in rows if r["code"] == name)
               for name in trees}
    busy = {name: [statistics.median(r["busy_ms"][k] for r in rows if r["code"] == name)
                   for k in range(2)] for name in trees}
    save_json(os.path.join(args.out, "effect.json"),
              {"case": CASE, "set": SETS, "weight": weight, "rows": rows, "median_ms": medians,
               "median_busy_ms": busy})
    lines = ["| code | step (ms, each repeat) | median | busy ms per step, rank 0 / 1 "
             "(medians) | busy max/mean - 1 | slab plane (cell) | elements per rank "
             "| imbalance plain / weighted |", "|---|---|---|---|---|---|---|---|"]
    for name in trees:
        mine = [r for r in rows if r["code"] == name]
        steps = ", ".join(f"{r['step_ms']:.2f}" for r in mine)
        lines.append(f"| {name} | {steps} | "
                     f"{medians[name]:.2f} | {busy[name][0]:.2f} / {busy[name][1]:.2f} | "
                     f"{max(busy[name]) / (sum(busy[name]) / 2) - 1:.2f} | "
                     f"{mine[-1]['bounds'][1]} | "
                     f"{mine[-1]['elements_per_rank']} | {mine[-1]['plain']:.2f} / "
                     f"{mine[-1]['weighted']:.2f} |")
    write_lines(os.path.join(args.out, "effect.md"), lines, echo=True)


if __name__ == "__main__":
    main()
