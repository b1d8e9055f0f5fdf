"""Strong scaling measured on a machine with a core per rank (issue 25): run a case of
``scripts/scaling.py`` at its target size on 1, 2, 4, ... ranks, the repeats interleaved,
and tabulate what was measured, beside what ``scaling.py``'s model leaves out.

    python scripts/scaling_cores.py [--case taylor|perforation] [--shape gimp]
        [--ranks 1 2 4 8 16] [--repeat 2] [--mpiexec "mpiexec -bind-to core"]
        [--no-frames] [--copies] [--out results/scaling_cores]

For every run the table gives the step loop's wall time per step and the efficiency
T(1) / (P T(P)) (medians over the repeats), the slab imbalance of particle counts, and
each rank's busy CPU time in the steps (``scripts/busy_time.py``: a step's CPU time
outside pmpm.comm): the busiest rank over the mean says how unequal the ranks' work was,
whatever its cause (particle counts, plastic work, slower cores). The total energy must
agree with 1 rank to ``--tolerance``.

``--copies`` also runs 1, then P, independent 1-rank copies of an eighth of the case at
once, one per core: the rate of a core when P cores are busy, over its rate alone, is what
the machine gives (shared memory bandwidth, clocks, a virtual machine's neighbours),
with no MPI in it.

``--no-frames`` drops the particle frames (summary.json and history.csv are written):
for a machine whose h5py is built without MPI, where pmpm cannot write particles.h5.
``--mpiexec`` is the launcher with its options (Open MPI: ``mpirun --bind-to core``;
MPICH: ``mpiexec -bind-to core``). Writes OUT/scaling_cores_CASE_SHAPE.{md,json}.
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import time

from _common import ENV, PYTHON, ROOT, write_lines
import scaling

HERE = os.path.abspath(__file__)


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", choices=sorted(scaling.CASES), default="taylor")
    p.add_argument("--shape", choices=("linear", "gimp", "bspline"), default=None)
    p.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 4, 8, 16])
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--steps-time", type=float, default=None,
                   help="time.end of the runs (ms); default: about 60 steps of the target")
    p.add_argument("--mpiexec", default="mpirun --bind-to core")
    p.add_argument("--no-frames", action="store_true")
    p.add_argument("--copies", action="store_true")
    p.add_argument("--tolerance", type=float, default=1e-10)
    p.add_argument("--latency-us", type=float, default=0.5,
                   help="the model's latency (default: shared memory)")
    p.add_argument("--bandwidth-gbs", type=float, default=5.0,
                   help="the model's bandwidth (default: shared memory)")
    p.add_argument("--out", default=os.path.join(ROOT, "results", "scaling_cores"))
    return p.parse_args(argv)


#: time.end (ms) giving about 60 steps at the target cell: the Taylor bar at 0.19 mm
#: steps 1.9e-5 ms, the perforation at 1 mm 6.7e-5 ms
STEPS_TIME = {"taylor": 0.0012, "perforation": 0.002}


#: the copies' case: an eighth of the target's particles (pmpm applies --set in order)
#: and long enough (about 80 steps) that the first step's jitter does not set the rate
COPY_SETS = {"taylor": ["params.cell=0.38", "time.end=0.003"],
             "perforation": ["params.ppc_plate=1", "params.ppc_rod=2", "time.end=0.005"]}


def target_sets(args):
    """The --set items of the target-size runs: the case's own, at the target cell."""
    case, sets, _, h_target, _, _ = scaling.CASES[args.case]
    end = args.steps_time or STEPS_TIME[args.case]
    sets = [s for s in sets if not s.startswith("time.end=")] + [
        f"params.cell={h_target:g}", f"time.end={end:g}"]
    if args.shape:
        sets.append(f"grid.shape_functions={args.shape}")
    return case, sets


def child_command(args, busy_json, out, case, sets):
    """This script in child mode: pmpm under busy_time's instrumentation."""
    cmd = [PYTHON if os.path.exists(PYTHON) else sys.executable, HERE, "--child", busy_json]
    cmd += ["--no-frames"] if args.no_frames else []
    cmd += ["--", os.path.join(ROOT, case), "--out", out, "--force", "--quiet"]
    for item in sets:
        cmd += ["--set", item]
    return cmd


def run_once(args, ranks, name, case, sets):
    """One run on ``ranks`` ranks; its summary with the per-rank busy times added."""
    out = os.path.join(args.out, "runs", name)
    busy = out + ".busy.json"
    cmd = child_command(args, busy, out, case, sets)
    if ranks > 1:
        cmd = shlex.split(args.mpiexec) + ["-n", str(ranks)] + cmd
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, env=ENV, cwd=ROOT)
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    with open(busy, encoding="utf-8") as f:
        summary["busy_cpu_s"] = [r["busy_cpu_s"] for r in json.load(f)["ranks"]]
    return summary


def run_copies(args, counts, case, sets):
    """{P: [rate of each of P independent 1-rank runs started together]}; P = 1 may
    come twice (alone before and after the others): its rates are pooled."""
    rates = {}
    for count in counts:
        procs, outs = [], []
        for i in range(count):
            out = os.path.join(args.out, "copies", f"c{count}_{i}")
            cmd = child_command(args, out + ".busy.json", out, case, sets)
            procs.append(subprocess.Popen(cmd, env=ENV, cwd=ROOT))
            outs.append(out)
        if any(p.wait() for p in procs):
            raise SystemExit(f"a copy failed ({count} at once)")
        rates.setdefault(count, []).extend(read_summary(o)["particle_steps_per_s"]
                                           for o in outs)
    return rates


def read_summary(out):
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        return json.load(f)


def measure(args):
    case, sets = target_sets(args)
    runs = {ranks: [] for ranks in args.ranks}
    for rep in range(args.repeat):
        for ranks in args.ranks:
            runs[ranks].append(run_once(args, ranks, f"r{ranks}_{rep}", case, sets))
    copies = None
    if args.copies:
        counts = [1] + [r for r in args.ranks if r > 1] + [1]
        copies = run_copies(args, counts, case, sets + COPY_SETS[args.case])
    return runs, copies


def step_s(summary):
    return summary["step_wall_s"] / max(summary["n_steps"], 1)


def table(args, runs, copies):
    """The page's lines."""
    base = statistics.median(step_s(s) for s in runs[min(runs)])
    e1 = runs[min(runs)][0]["energy"]["total"]
    first = runs[min(runs)][0]
    lines = [f"# Strong scaling on {os.cpu_count()} cores: {scaling.CASES[args.case][4]}"
             f"{', ' + args.shape if args.shape else ''}", "",
             f"{first['n_particles']['initial']:,} particles, {first['n_steps']} steps, "
             f"{args.repeat} repeats interleaved, medians; launcher `{args.mpiexec}`.", "",
             "| ranks | ms per step | efficiency | efficiency range | scaling.py's model | "
             "particle imbalance | busiest rank's busy CPU / mean | neighbour messages, kB "
             "per step (busiest) | bytes/particle | energy vs 1 rank |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    worst = 0.0
    for ranks, summaries in runs.items():
        effs = [base / (ranks * step_s(s)) for s in summaries]
        busy = summaries[0]["busy_cpu_s"]
        diff = max(abs(s["energy"]["total"] - e1) / abs(e1) for s in summaries)
        worst = max(worst, diff)
        nb = summaries[0]["communication"]["neighbour"]
        lines.append(
            f"| {ranks} | {1e3 * statistics.median(step_s(s) for s in summaries):.1f} | "
            f"{100 * statistics.median(effs):.0f} % | {100 * min(effs):.0f}-"
            f"{100 * max(effs):.0f} % | {100 * modelled(base, ranks, summaries[0], args):.0f} % | "
            f"{1 + summaries[0]['slabs']['imbalance']:.3f} | "
            f"{max(busy) / statistics.mean(busy):.2f} | "
            f"{nb['messages_per_step']['largest']:.0f}, "
            f"{nb['bytes_per_step']['largest'] / 1e3:,.0f} | "
            f"{summaries[0]['memory']['bytes_per_particle']:.0f} | {diff:.1e} |")
    if copies:
        alone = statistics.median(copies[1])
        lines += ["", "Independent 1-rank copies of an eighth of the case started together, one "
                  "per core (no MPI): each copy's rate over one copy alone.", "",
                  "| copies at once | median | slowest |", "|---|---|---|"]
        for count, rates in copies.items():
            if count > 1:
                lines.append(f"| {count} | {statistics.median(rates) / alone:.2f} | "
                             f"{min(rates) / alone:.2f} |")
    lines += ["", f"Total energy agrees with 1 rank to {worst:.1e} "
                  f"({'within' if worst <= args.tolerance else 'NOT within'} "
                  f"{args.tolerance:g})."]
    return lines, worst <= args.tolerance


def modelled(base, ranks, summary, args):
    """The efficiency scaling.py's model gives for this run: the 1-rank step divided
    over the ranks times the run's particle imbalance, plus its counted messages at
    ``--latency-us`` and ``--bandwidth-gbs`` (t_0 taken as 0: one rank's step is all
    per-particle work)."""
    busy = lambda kind, what: summary["communication"][kind][what]["largest"]
    comm = {"m_nb": busy("neighbour", "messages_per_step"),
            "b_nb": busy("neighbour", "bytes_per_step"),
            "m_coll": busy("collective", "messages_per_step"),
            "m_a2a": busy("alltoall", "messages_per_step"),
            "b_a2a": busy("alltoall", "bytes_per_step")}
    n = summary["n_particles"]["initial"]
    step = scaling.model(base / n, n, ranks, 1 + summary["slabs"]["imbalance"], comm,
                         args.latency_us * 1e-6, args.bandwidth_gbs * 1e9)
    return base / (ranks * step)


def child(argv):
    """``--child BUSY_JSON [--no-frames] -- PMPM_ARGS``: pmpm under busy_time."""
    busy_json, rest = argv[0], argv[1:]
    no_frames = rest[:1] == ["--no-frames"]
    rest = rest[1:] if no_frames else rest
    pmpm_args = rest[1:] if rest[:1] == ["--"] else rest
    sys.path.insert(0, ROOT)
    import busy_time
    if no_frames:
        drop_frames()
    sys.argv = [busy_time.__file__, ROOT, busy_json] + pmpm_args
    busy_time.main()


class _NoFrames:
    """A particle writer that writes nothing (``--no-frames``)."""

    def __init__(self, *args, **kwargs):
        self.n_frames = 0

    def write_frame(self, *args, **kwargs):
        pass

    def close(self, *args, **kwargs):
        pass


def drop_frames():
    import pmpm.io
    pmpm.io.ParticleWriter = _NoFrames


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        return child(argv[1:])
    args = parse_args(argv)
    started = time.perf_counter()
    runs, copies = measure(args)
    lines, ok = table(args, runs, copies)
    lines.append(f"Measured in {time.perf_counter() - started:.0f} s.")
    name = f"scaling_cores_{args.case}_{args.shape or 'file'}"
    write_lines(os.path.join(args.out, name + ".md"), lines, echo=True)
    with open(os.path.join(args.out, name + ".json"), "w", encoding="utf-8") as f:
        json.dump({"runs": {r: s for r, s in runs.items()}, "copies": copies}, f, indent=1)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
