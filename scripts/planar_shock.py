"""Planar impact of copper on copper at 1000 m/s in uniaxial strain (issue 14) against the
Rankine-Hugoniot jump: energy growth, shock speed, pressure, density and particle
velocity behind the shock, for USF and MUSL at cfl 0.5 and 0.1, in two frames of
reference (the target at rest, as the issue ran it, and the symmetric frame where the
shocked copper is at rest on the grid), and the diagnostic runs that locate the energy
gain (bulk viscosity off, Grueneisen term off, a linear EOS, 10 m/s, smaller steps, other
particle counts). Writes results/planar_shock/planar_shock.{json,md}.

Each run is 1,920 particles and 200-6,000 steps: seconds each, about 2 minutes in all.

Usage: .venv/bin/python scripts/planar_shock.py [--only NAME ...] [--out DIR]
"""
import argparse
import os
import subprocess

from _common import ROOT, run_case, save_json, write_lines

from pmpm.post import read_history
from pmpm.post.shock import planar_shock_errors

CASE = "runs/planar_shock.yaml"
RHO0, C0, S = 8.93e-3, 3940.0, 1.49
NO_Q = "materials.copper.bulk_viscosity={quadratic: 0, linear: 0}"
SYM = "params.v_flyer=500"             # the symmetric frame: flyer +500, target -500 m/s

#: name -> (what it shows, --set overrides)
RUNS = {
    "usf_0.5": ("the issue's run: target at rest, USF, cfl 0.5", []),
    "usf_0.1": ("USF, cfl 0.1", ["time.cfl=0.1"]),
    "musl_0.5": ("MUSL, cfl 0.5", ["time.scheme=musl"]),
    "musl_0.1": ("MUSL, cfl 0.1", ["time.scheme=musl", "time.cfl=0.1"]),
    "sym_usf_0.5": ("symmetric frame, USF, cfl 0.5", [SYM]),
    "sym_usf_0.2": ("symmetric frame, USF, cfl 0.2", [SYM, "time.cfl=0.2"]),
    "sym_usf_0.1": ("symmetric frame, USF, cfl 0.1", [SYM, "time.cfl=0.1"]),
    "sym_musl_0.5": ("symmetric frame, MUSL, cfl 0.5", [SYM, "time.scheme=musl"]),
    "sym_musl_0.1": ("symmetric frame, MUSL, cfl 0.1", [SYM, "time.scheme=musl",
                                                         "time.cfl=0.1"]),
    "no_q": ("bulk viscosity off", [NO_Q]),
    "gamma0_0": ("Grueneisen term off (gamma0 = 0)", ["materials.copper.eos.gamma0=0"]),
    "linear_no_q": ("linear EOS p = rho0 c0^2 mu, no bulk viscosity: no energy term at all",
                    ["materials.copper.eos={type: linear, c0: 3940}", NO_Q]),
    "v10": ("10 m/s (no particle crosses a cell)", ["params.v_rel=10", "params.v_flyer=10"]),
    "v100_linear_no_q": ("100 m/s, linear EOS, no bulk viscosity",
                         ["params.v_rel=100", "params.v_flyer=100",
                          "materials.copper.eos={type: linear, c0: 3940}", NO_Q]),
    "usf_0.05": ("USF, cfl 0.05", ["time.cfl=0.05"]),
    "usf_0.025": ("USF, cfl 0.025", ["time.cfl=0.025"]),
    "sym_usf_0.025": ("symmetric frame, USF, cfl 0.025", [SYM, "time.cfl=0.025"]),
    "ppc1": ("1 particle per cell, 0.025 mm cells (same 40 per mm)",
             ["params.ppc=1", "params.cell=0.025"]),
    "ppc3": ("3 particles per cell, 0.075 mm cells (same 40 per mm)",
             ["params.ppc=3", "params.cell=0.075"]),
    "pic_0.05": ("5 % PIC blend", ["time.pic=0.05"]),
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=sorted(RUNS), default=None)
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "planar_shock"))
    args = parser.parse_args()
    rows = []
    for name in args.only or RUNS:
        what, sets = RUNS[name]
        out = os.path.join(args.out, name)
        try:
            summary = run_case(CASE, out, 1, sets)
        except subprocess.CalledProcessError:
            rows.append(failed_row(name, what, sets, out))
            continue
        rows.append(row(name, what, sets, out, summary))
    save_json(os.path.join(args.out, "planar_shock.json"), rows)
    write_table(os.path.join(args.out, "planar_shock.md"), rows)


def velocities(sets):
    """(v_flyer, v_target) of a run from its overrides and the case's defaults."""
    values = {"v_rel": 1000.0, "v_flyer": 1000.0}
    for item in sets:
        key, _, value = item.partition("=")
        if key.startswith("params.") and key[7:] in values:
            values[key[7:]] = float(value)
    return values["v_flyer"], values["v_flyer"] - values["v_rel"]


def row(name, what, sets, out, summary):
    v_flyer, v_target = velocities(sets)
    measured = planar_shock_errors(out, v_flyer, v_target, RHO0, C0, S)
    balance = summary["energy_balance"]
    return {"name": name, "what": what, "sets": sets, "n_steps": summary["n_steps"],
            "growth": balance["growth"], "largest_growth": balance["largest_growth"],
            "errors": measured["errors"],
            "scatter": {b: measured[b]["p_sd"] / measured["exact"]["P"]
                        for b in ("flyer", "target")},
            "exact": measured["exact"]}


def failed_row(name, what, sets, out):
    """A run stopped by a fault: its energy growth at the last history row."""
    history = read_history(out)
    total = history["total"]
    return {"name": name, "what": what, "sets": sets, "failed_at": float(history["time"][-1]),
            "n_steps": int(history["step"][-1]), "growth": total[-1] / total[0] - 1.0,
            "largest_growth": max(total) / total[0] - 1.0}


def write_table(path, rows):
    lines = ["Energy: growth of the total energy at 1.2 us (largest). Errors: relative, "
             "plateau means of the target (flyer); scatter: plateau pressure standard "
             "deviation / P.", "",
             "| run | steps | energy | Us | P | rho | up | P scatter |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "failed_at" in r:
            lines.append(f"| {r['what']} | {r['n_steps']} | {100 * r['growth']:+.1f} % "
                         f"at {1e3 * r['failed_at']:.2f} us, then a failed update "
                         "| | | | | |")
            continue
        t, f = r["errors"]["target"], r["errors"]["flyer"]
        cells = " | ".join(f"{100 * t[k]:+.1f} ({100 * f[k]:+.1f})"
                           for k in ("Us", "P", "rho", "up"))
        lines.append(f"| {r['what']} | {r['n_steps']} | {100 * r['growth']:+.1f} % "
                     f"({100 * r['largest_growth']:+.1f}) | {cells} | "
                     f"{r['scatter']['target']:.2f} |")
    write_lines(path, lines, echo=True)


if __name__ == "__main__":
    main()
