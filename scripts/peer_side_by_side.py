"""pmpm against the seed group's MPM3D-F90, side by side on one core (issue 25): the seed
Taylor bar (runs/taylor_bar.yaml) with pmpm's gimp (its default shapes) and linear hats,
and MPM3D-F90 with its hats and its GIMP, run interleaved, one process at a time.

MPM3D-F90 is not part of pmpm: build it yourself and adapt its Data/Taylor.mpm to the
case (same geometry, material, cell, particles and end time); give the folder holding
the two adapted inputs, ``Taylor_hats.mpm`` and ``Taylor_gimp.mpm`` (the same input with
the ``gimp`` keyword). Per run it records the whole-process wall seconds, the steps, the
step-loop rate (pmpm: summary.json; MPM3D-F90: its own "Time per particle cycle", which
times the step loop without output), the final L and D (pmpm.post.taylor_shape on the
final particle centres) and the energy error; it prints the medians and writes
results/peer_side_by_side/<name>.{json,md}.

Usage: .venv/bin/python scripts/peer_side_by_side.py --f90 PATH/mpm3d-f90 --input DIR
           [--repeat 3] [--cell 0.76] [--end 0.08] [--name peer]
"""
import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import time

import numpy as np

from _common import ENV, PYTHON, ROOT, provenance, save_json, write_lines

from pmpm.post import read_frame, taylor_shape

EXPERIMENT = (16.2, 13.5)   # Johnson et al.: L, D (mm) at 80 us
VARIANTS = (("pmpm gimp (default)", "pmpm", "gimp"), ("pmpm linear", "pmpm", "linear"),
            ("F90 hats (default)", "f90", "hats"), ("F90 GIMP", "f90", "gimp"))
F90_INPUT = {"hats": "Taylor_hats.mpm", "gimp": "Taylor_gimp.mpm"}


def main(argv=None):
    args = parse_args(argv)
    f90, inputs = check_f90(args)
    work = os.path.abspath(args.work)
    os.makedirs(work, exist_ok=True)
    for shapes in ("gimp", "linear"):   # warm numba's cache: no compile inside the timings
        run_pmpm(args, shapes, os.path.join(work, f"warm_{shapes}"), end=min(args.end, 0.002))
    runs = []
    for repeat in range(args.repeat):
        for label, code, shapes in VARIANTS:
            out = os.path.join(work, f"{code}_{shapes}_{repeat}")
            row = (run_pmpm(args, shapes, out) if code == "pmpm"
                   else run_f90(f90, inputs[shapes], out))
            row.update(variant=label, repeat=repeat)
            print(f"  {label}: {row['wall_s']:.1f} s, {row['n_steps']} steps, "
                  f"L {row['L']:.2f}, D {row['D']:.2f}", flush=True)
            runs.append(row)
    rows = medians(runs)
    result = {**provenance("peer_side_by_side.py"), "cell": args.cell, "t_end": args.end,
              "repeat": args.repeat, "rows": rows,
              "ratios": ratios(rows), "runs": runs, "experiment": EXPERIMENT}
    dest = os.path.join(ROOT, "results", "peer_side_by_side")
    save_json(os.path.join(dest, f"{args.name}.json"), result)
    write_lines(os.path.join(dest, f"{args.name}.md"), table(result), echo=True)


def parse_args(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="\n".join(__doc__.splitlines()[1:]))
    parser.add_argument("--f90", help="the MPM3D-F90 executable (required)")
    parser.add_argument("--input", help="folder holding Taylor_hats.mpm and Taylor_gimp.mpm "
                        "(required)")
    parser.add_argument("--repeat", type=int, default=3, help="interleaved rounds (default 3)")
    parser.add_argument("--cell", type=float, default=0.76, help="cell edge, mm (default 0.76)")
    parser.add_argument("--end", type=float, default=0.08, help="end time, ms (default 0.08)")
    parser.add_argument("--name", default="peer", help="result file name (default peer)")
    parser.add_argument("--work", default="/tmp/peer_side_by_side",
                        help="scratch folder for the runs' output")
    return parser.parse_args(argv)


def check_f90(args):
    """The executable and the two inputs, or exit with a message naming what is missing or
    does not match --cell and --end."""
    if not args.f90:
        sys.exit("peer_side_by_side: give --f90 PATH, the MPM3D-F90 executable (build it "
                 "outside pmpm; see docs/performance-notes.md, 'Side by side with MPM3D-F90')")
    if not (os.path.isfile(args.f90) and os.access(args.f90, os.X_OK)):
        sys.exit(f"peer_side_by_side: --f90 {args.f90} is not an executable file")
    if not args.input:
        sys.exit("peer_side_by_side: give --input DIR holding Taylor_hats.mpm and "
                 "Taylor_gimp.mpm (MPM3D-F90 inputs adapted to runs/taylor_bar.yaml)")
    inputs = {}
    for shapes, name in F90_INPUT.items():
        path = os.path.join(args.input, name)
        if not os.path.isfile(path):
            sys.exit(f"peer_side_by_side: --input {args.input} has no {name}")
        keys = f90_keys(path)
        for key, want in (("dcell", args.cell), ("endtime", args.end)):
            if key not in keys or abs(keys[key] - want) > 1e-9 * max(1.0, want):
                sys.exit(f"peer_side_by_side: {path}: '{key}' is {keys.get(key)}, "
                         f"but --{'cell' if key == 'dcell' else 'end'} is {want}")
        if ("gimp" in keys) != (shapes == "gimp"):
            sys.exit(f"peer_side_by_side: {path}: the 'gimp' keyword must be "
                     f"{'present' if shapes == 'gimp' else 'absent'}")
        inputs[shapes] = os.path.abspath(path)
    return os.path.abspath(args.f90), inputs


def f90_keys(path):
    """The first value of MPM3D-F90's header keywords (dcell, endtime, gimp) in ``path``."""
    keys = {}
    with open(path, encoding="utf-8", errors="replace") as f:
        for line in f:
            words = line.split("!")[0].split()
            if not words:
                continue
            if words[0].lower() == "particle":
                break
            word = words[0].lower()
            if word in ("dcell", "endtime") and word not in keys:
                keys[word] = float(words[1].replace("d", "e"))
            elif word == "gimp":
                keys["gimp"] = 1.0
    return keys


def run_pmpm(args, shapes, out, end=None):
    """One pmpm process on one rank; the row of its summary.json and final frame."""
    cmd = [PYTHON if os.path.exists(PYTHON) else sys.executable, "-m", "pmpm",
           os.path.join(ROOT, "runs", "taylor_bar.yaml"), "--out", out, "--force", "--quiet",
           "--set", f"params.cell={args.cell}", "--set", f"grid.shape_functions={shapes}",
           "--set", f"time.end={args.end if end is None else end}"]
    wall = timed(cmd, cwd=ROOT)
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        summary = json.load(f)
    hist = np.genfromtxt(os.path.join(out, "history.csv"), delimiter=",", names=True)
    return {"wall_s": wall, "n_steps": summary["n_steps"],
            "n_particles": summary["n_particles"]["initial"],
            "step_s": summary["step_wall_s"],
            "particle_steps_per_s": summary["particle_steps_per_s"],
            "energy_error": float((hist["total"][-1] - hist["total"][0]) / hist["total"][0]),
            **taylor_shape(read_frame(out)["x"])}


def run_f90(f90, inp, out):
    """One MPM3D-F90 process in a fresh folder ``out``; its timing lines, energies and the
    last Tecplot zone's particle centres."""
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    shutil.copy(inp, out)
    stem = os.path.splitext(os.path.basename(inp))[0]
    log = os.path.join(out, "stdout.txt")
    wall = timed([f90, stem], cwd=out, log=log)
    with open(log, encoding="utf-8", errors="replace") as f:
        text = f.read()
    steps = [(int(s), float(e)) for s, e in
             re.findall(r"Step=\s*(\d+)\s+T=.*?T\.E\.=\s*([-+0-9.Ee]+)", text)]
    cycle_ns = float(re.search(r"Time per particle cycle:\s*([0-9.Ee+-]+)", text).group(1))
    loop_s = float(re.search(r"Total CPU Time is\s*([0-9.Ee+-]+)", text).group(1))
    n_particles = int(re.search(r"Number of particles =\s*(\d+)", text).group(1))
    # Its own rate is CPU time (cpu_time); the solve's wall time (secnds) includes output.
    solve_wall = float(re.search(r"Total elasped time :\s*([0-9.Ee+-]+)", text).group(1))
    # The energy at T = 0 is the initial kinetic energy (no stress yet): the first report
    # comes after one step, on an unloaded bar, so it still equals it.
    x = last_tecplot_zone(os.path.join(out, f"{stem}_anim.dat"))
    return {"wall_s": wall, "n_steps": steps[-1][0], "n_particles": n_particles,
            "step_s": loop_s, "particle_steps_per_s": 1e9 / cycle_ns,
            "solve_wall_s": solve_wall,
            "particle_steps_per_wall_s": n_particles * steps[-1][0] / solve_wall,
            "energy_error": (steps[-1][1] - steps[0][1]) / steps[0][1], **taylor_shape(x)}


def last_tecplot_zone(path):
    """Particle centres (first three columns) of the last ZONE in MPM3D-F90's _anim.dat."""
    with open(path, encoding="utf-8", errors="replace") as f:
        text = f.read()
    zone = text[text.rindex("ZONE"):].split("\n", 1)[1]
    rows = [line.split()[:3] for line in zone.splitlines() if line.strip()]
    return np.array(rows, dtype=np.float64)


def timed(cmd, cwd, log=None):
    """Whole-process wall seconds of ``cmd`` (single-threaded environment); raises with
    the tail of its output when it fails."""
    print("+", " ".join(cmd), flush=True)
    start = time.perf_counter()
    proc = subprocess.run(cmd, cwd=cwd, env=ENV, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, errors="replace")
    wall = time.perf_counter() - start
    if log:
        with open(log, "w", encoding="utf-8") as f:
            f.write(proc.stdout)
    if proc.returncode != 0:
        raise RuntimeError(f"{cmd[0]} failed ({proc.returncode}):\n{proc.stdout[-2000:]}")
    return wall


def medians(runs):
    """One row per variant: the median of each number over the repeats."""
    rows = []
    for label, _, _ in VARIANTS:
        mine = [r for r in runs if r["variant"] == label]
        row = {"variant": label}
        for key in ("wall_s", "n_steps", "n_particles", "step_s", "particle_steps_per_s",
                    "energy_error", "L", "D", "D_widest"):
            row[key] = statistics.median(r[key] for r in mine)
        row["wall_s_all"] = [r["wall_s"] for r in mine]
        rows.append(row)
    return rows


def ratios(rows):
    """pmpm's default against MPM3D-F90's default (time to solution, whole process and
    step loop) and against its GIMP (particle-steps per second in the step loop)."""
    by = {r["variant"]: r for r in rows}
    pm, hats, gimp = by[VARIANTS[0][0]], by[VARIANTS[2][0]], by[VARIANTS[3][0]]
    return {"time_f90_default_over_pmpm_default": hats["wall_s"] / pm["wall_s"],
            "step_loop_f90_default_over_pmpm_default": hats["step_s"] / pm["step_s"],
            "rate_pmpm_default_over_f90_default":
                pm["particle_steps_per_s"] / hats["particle_steps_per_s"],
            "rate_pmpm_default_over_f90_gimp":
                pm["particle_steps_per_s"] / gimp["particle_steps_per_s"],
            "time_f90_gimp_over_pmpm_default": gimp["wall_s"] / pm["wall_s"]}


def table(result):
    lines = [f"Taylor bar, cell {result['cell']} mm, to {result['t_end']} ms, one core each, "
             f"medians of {result['repeat']} interleaved runs.", "",
             "| variant | particles | steps | whole process s | step loop s | "
             "M particle-steps/s | L mm | D mm | D widest mm | energy error |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["rows"]:
        lines.append(f"| {r['variant']} | {r['n_particles']:.0f} | {r['n_steps']:.0f} | "
                     f"{r['wall_s']:.1f} | {r['step_s']:.1f} | "
                     f"{r['particle_steps_per_s'] / 1e6:.2f} | {r['L']:.2f} | {r['D']:.2f} | "
                     f"{r['D_widest']:.2f} | {100 * r['energy_error']:+.2f} % |")
    q = result["ratios"]
    lines += [""]
    if abs(result["t_end"] - 0.08) < 1e-12:
        lines.append(f"Experiment: L = {EXPERIMENT[0]}, D = {EXPERIMENT[1]} mm (at 80 us).")
    lines += [f"F90 default / pmpm default, whole process: "
              f"{q['time_f90_default_over_pmpm_default']:.2f}; step loop: "
              f"{q['step_loop_f90_default_over_pmpm_default']:.2f}.",
              f"pmpm default / F90 default, particle-steps per s: "
              f"{q['rate_pmpm_default_over_f90_default']:.2f}; pmpm default / F90 GIMP: "
              f"{q['rate_pmpm_default_over_f90_gimp']:.2f}."]
    return lines


if __name__ == "__main__":
    main()
