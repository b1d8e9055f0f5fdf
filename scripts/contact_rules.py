"""Seed 001's contact cases under each contact rule, in one table (issue 15).

The rules: seed 001's own detection (`paper`), the separation check of the steel ball's
case file (`check`, contact.separation: 0.9) and the release rule with each gap measure
(`reach`, `volume`: contact.release: 0 and contact.gap). Each case is run by its own
script (rings.py, sphere_rolling.py, steel_ball_plate.py, ogive_plate.py) into
results/contact_rules/<case>_<rule>[_v<speed>]/; this script runs the matrix asked for
(--run) and writes one table from whatever results are there.

    python scripts/contact_rules.py --run --cases rings sphere_rolling --rules paper volume
    python scripts/contact_rules.py          # the table from the saved results
"""
import argparse
import json
import os
import subprocess

from _common import ROOT, PYTHON, ENV, write_lines

OUT = os.path.join(ROOT, "results", "contact_rules")
RULES = {
    "paper": ["contact.separation=none", "contact.release=none"],
    "check": ["contact.separation=0.9", "contact.release=none"],
    "reach": ["contact.separation=none", "contact.release=0", "contact.gap=reach"],
    "volume": ["contact.separation=none", "contact.release=0", "contact.gap=volume"],
}
RULE_TITLES = {"paper": "seed 001 (paper's detection)", "check": "separation check 0.9",
               "reach": "release, reach gap", "volume": "release, volume gap"}
SPEEDS = (340, 400, 446, 575, 730)
CASES = ("rings", "sphere_rolling", "steel_ball", "ogive")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    parser.add_argument("--rules", nargs="+", choices=sorted(RULES), default=sorted(RULES))
    parser.add_argument("--speeds", type=int, nargs="+", default=list(SPEEDS),
                        help="ogive striking speeds (m/s)")
    parser.add_argument("--run", action="store_true", help="run the matrix first")
    parser.add_argument("--out", default=OUT)
    args = parser.parse_args()
    if args.run:
        for case in args.cases:
            for rule in args.rules:
                run(case, rule, args)
    rows = table_rows(args.out)
    write_lines(os.path.join(args.out, "contact_rules.md"), table(rows), echo=True)


def run(case, rule, args):
    """One case under one rule through the case's own script (2 ranks)."""
    sets = [arg for item in RULES[rule] for arg in ("--set", item)]
    if case == "ogive":
        for v0 in args.speeds:
            script("ogive_plate.py", ["--methods", "2", "--speeds", str(v0)] + sets,
                   os.path.join(args.out, f"ogive_{rule}_v{v0}"))
    elif case == "steel_ball":
        script("steel_ball_plate.py", ["--methods", "2"] + sets,
               os.path.join(args.out, f"steel_ball_{rule}"))
    elif case == "rings":
        script("rings.py", ["--ranks", "2", "--cfl", "0.5", "--methods", "1", "2"] + sets,
               os.path.join(args.out, f"rings_{rule}"))
    else:
        script("sphere_rolling.py", ["--methods", "2"] + sets,
               os.path.join(args.out, f"sphere_rolling_{rule}"))


def script(name, arguments, out):
    cmd = [PYTHON, os.path.join(ROOT, "scripts", name), *arguments, "--out", out]
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, env=ENV, cwd=ROOT)


def load(path):
    if not os.path.exists(path):
        return None
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def table_rows(out):
    """``[(case, quantity, reference, {rule: text})]`` from the saved results."""
    rows = []
    for method in (1, 2):
        found = {rule: next((r for r in load(os.path.join(out, f"rings_{rule}", "rings.json"))
                             or [] if r["method"] == method), None) for rule in RULES}
        rows.append((f"rings, method {method}", "separate at (ms)", "3.4 (paper)",
                     {k: r and f"{r['separation_time']:.2f}" for k, r in found.items()}))
        rows.append((f"rings, method {method}", "energy drift while touching / K0",
                     "level (paper, method 2)",
                     {k: r and f"{100 * r['contact_drift']:+.1f} %" for k, r in found.items()}))
    for regime in ("stick", "slip"):
        found = {rule: next((r for r in load(os.path.join(
            out, f"sphere_rolling_{rule}", "sphere_rolling.json")) or []
            if r["case"] == regime and r["method"] == 2), None) for rule in RULES}
        rows.append((f"rolling sphere, {regime}, method 2", "travel at 2 s (m)",
                     next((f"{r['eq36'] / 1e3:.3f} (Eq. 36)" for r in found.values() if r), ""),
                     {k: r and f"{r['travel'] / 1e3:.3f} ({100 * r['error']:+.1f} %)"
                      for k, r in found.items()}))
    found = {rule: (load(os.path.join(out, f"steel_ball_{rule}", "steel_ball_plate.json"))
                    or [None])[0] for rule in RULES}
    rows.append(("steel ball, 0.66 mm, method 2", "V_r (m/s)", "72.6 (Table II)",
                 {k: r and (f"{r['V_r']:.1f}" + ("" if r["perforated"] else " (held)"))
                  for k, r in found.items()}))
    rows.append(("steel ball, 0.66 mm, method 2", "h/D", "0.94 (Table II), 0.84 (experiment)",
                 {k: r and (f"{r['h_over_D']:.2f}" if r["hole"] else "no hole")
                  for k, r in found.items()}))
    for v0 in SPEEDS:
        found = {rule: (load(os.path.join(out, f"ogive_{rule}_v{v0}", "ogive_plate.json"))
                        or [None])[0] for rule in RULES}
        rows.append((f"ogive, {v0} m/s, method 2", "V_r (m/s)",
                     next((f"{r['experiment']:g} (experiment), {r['paper']:g} (paper)"
                           for r in found.values() if r), ""),
                     {k: r and (f"{r['V_r']:.1f}" if r["exited"] else
                                f"0 ({r['speed_end']:.1f} in the plate)")
                      for k, r in found.items()}))
    return rows


def table(rows):
    rules = list(RULES)
    lines = ["| case | quantity | reference | " + " | ".join(RULE_TITLES[r] for r in rules)
             + " |", "|---|---|---|" + "---|" * len(rules)]
    for case, quantity, reference, cells in rows:
        if not any(cells.values()):
            continue
        lines.append(f"| {case} | {quantity} | {reference} | "
                     + " | ".join(cells[r] or "not run" for r in rules) + " |")
    lines.append("\nThe rings and the rolling sphere have no separation check in their case "
                 "files, so their `paper` and `check` columns differ only if run. 2 ranks.")
    return lines


if __name__ == "__main__":
    main()
