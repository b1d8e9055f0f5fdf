"""Angular momentum through the particle-grid transfers (issue 15): a free spinning cube,
and a sphere's oblique sliding impact on a frictional wall and on a plate through grid
contact, with each transfer (time.transfer: apic or flip; pic: flip with time.pic 1).

Writes results/angular_momentum/angular_momentum.{json,md}; docs/validation/
angular_momentum.md gives the table. 1 rank (the runs are small).

    python scripts/angular_momentum.py [--cells 1.0 0.5] [--out DIR]
"""
import argparse
import os

from _common import ROOT, run_case, save_json, write_lines
from pmpm.post import frame_times, read_frame, oblique_impact, spin_about_centroid

CASES = os.path.join("tests", "cases")
SPIN = os.path.join(CASES, "spinning_cube.yaml")
IMPACTS = {"wall": os.path.join(CASES, "oblique_impact.yaml"),
           "plate": os.path.join(CASES, "oblique_impact_plate.yaml")}
TRANSFERS = {"apic": ["time.transfer=apic"], "flip": ["time.transfer=flip"],
             "pic": ["time.transfer=flip", "time.pic=1"]}
RELEASE = ["contact.release=0", "contact.gap=volume"]
RADIUS, MU = 4.0, 0.2


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=float, nargs="+", default=[1.0, 0.5],
                        help="cell edges of the impacts (mm; the sphere's radius is 4)")
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "angular_momentum"))
    args = parser.parse_args()
    spins = [spinning_cube(name, args.out) for name in TRANSFERS]
    impacts = [impact(target, name, cell, rule, args.out)
               for target in IMPACTS for cell in args.cells
               for name, rule in runs_of(target)]
    save_json(os.path.join(args.out, "angular_momentum.json"),
              {"spinning_cube": spins, "impacts": impacts})
    write_lines(os.path.join(args.out, "angular_momentum.md"), table(spins, impacts),
                echo=True)


def runs_of(target):
    """(transfer, contact rule) pairs: the plate also under the release rule."""
    runs = [("apic", "seed 001"), ("flip", "seed 001")]
    return runs + [("apic", "release, volume gap")] if target == "plate" else runs


def spinning_cube(name, out_root):
    """The fraction of its angular momentum the free cube keeps after one and two
    revolutions (3 and 6 ms)."""
    out = os.path.join(out_root, f"spin_{name}")
    summary = run_case(SPIN, out, 1, TRANSFERS[name])
    L = [spin_about_centroid(read_frame(out, i), 1.0)[2]
         for i in range(len(frame_times(out)))]
    return {"transfer": name, "kept_1": L[1] / L[0], "kept_2": L[-1] / L[0],
            "wall_s": summary["wall_s"]}


def impact(target, name, cell, rule, out_root):
    tag = "release" if rule.startswith("release") else "seed"
    out = os.path.join(out_root, f"{target}_{name}_{tag}_cell{cell:g}")
    sets = TRANSFERS[name] + [f"grid.cell={cell}"] + (RELEASE if tag == "release" else [])
    summary = run_case(IMPACTS[target], out, 1, sets)
    return {"target": target, "transfer": name, "rule": rule, "cell": cell,
            "cells_per_radius": RADIUS / cell, **oblique_impact(out, cell, RADIUS),
            "n_particles": summary["n_particles"]["initial"], "wall_s": summary["wall_s"]}


def table(spins, impacts):
    lines = ["Free spinning cube (tests/cases/spinning_cube.yaml): angular momentum kept",
             "", "| transfer | after 1 revolution | after 2 | wall s |", "|---|---|---|---|"]
    lines += [f"| {s['transfer']} | {s['kept_1']:.4f} | {s['kept_2']:.4f} | "
              f"{s['wall_s']:.0f} |" for s in spins]
    lines += ["", f"Oblique sliding impact (mu = {MU}, R = {RADIUS:g} mm): J_t / J_n "
              "against mu, and the spin against the moment R |J_t| of the tangential "
              "impulse (rigid-body theory: 1)", "",
              "| target | contact | cells per radius | transfer | J_t / J_n | spin / (R J_t) "
              "| particles | wall s |", "|---|---|---|---|---|---|---|---|"]
    for r in impacts:
        contact = "friction face" if r["target"] == "wall" else f"grid, {r['rule']}"
        lines.append(f"| {r['target']} | {contact} | {r['cells_per_radius']:g} | "
                     f"{r['transfer']} | {r['ratio']:.4f} | {r['spin_kept']:.4f} | "
                     f"{r['n_particles']} | {r['wall_s']:.0f} |")
    return lines


if __name__ == "__main__":
    main()
