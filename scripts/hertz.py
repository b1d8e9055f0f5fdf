"""Hertz: two elastic spheres meeting head-on, under refinement of the contact zone, with
the release rule's two gap measures (issue 15). Writes results/hertz/hertz.{json,md}.

The case is tests/cases/hertz.yaml (0.5 mm coarse cells; a window refined `ratio` times
covers the contact zone). Each row gives the peak force, contact time and largest
approach against Hertz, the rebound speed over the impact speed and the change of the
total energy, and the order of convergence between successive refinements.

Usage: .venv/bin/python scripts/hertz.py [--ranks 2] [--ratios 1 2 4] [--gaps volume reach]
"""
import argparse
import math
import os

from _common import ROOT, run_case, save_json, write_lines

from pmpm.post import hertz_answer, hertz_measures

CASE = "tests/cases/hertz.yaml"
RADIUS, CELL = 5.0, 0.5
ANSWER = hertz_answer(RADIUS, 7.85e-3, 2.0e5, 0.3, 50.0)
KEYS = ("force", "contact_time", "approach")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--ratios", type=int, nargs="+", default=[1, 2, 4])
    parser.add_argument("--gaps", nargs="+", default=["volume", "reach"])
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "hertz"))
    args = parser.parse_args()
    rows = []
    for gap in args.gaps:
        for ratio in args.ratios:
            out = os.path.join(args.out, f"{gap}_r{ratio}")
            summary = run_case(CASE, out, args.ranks, [f"params.ratio={ratio}",
                                                       f"contact.gap={gap}"])
            rows.append({"gap": gap, "ratio": ratio, "cell": CELL / ratio,
                         "wall_s": summary["wall_s"],
                         "particles": sum(b["n_particles"] for b in summary["bodies"].values()),
                         **hertz_measures(out, ANSWER, RADIUS)})
    save_json(os.path.join(args.out, "hertz.json"), rows)
    write_lines(os.path.join(args.out, "hertz.md"), table(rows), echo=True)


def table(rows):
    lines = [f"Hertz: force {ANSWER.force:.0f} N, contact time {1e3 * ANSWER.contact_time:.2f}"
             f" us, approach {ANSWER.approach:.3f} mm, contact radius {ANSWER.radius:.2f} mm",
             "",
             "| gap | cell in the contact zone (mm) | a / cell | peak force | contact time | "
             "approach | order (force, time, approach) | rebound | energy | particles | wall (s) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    previous = {}
    for r in rows:
        before = previous.get(r["gap"])
        order = ", ".join(convergence_order(before, r, k) for k in KEYS) if before else ""
        lines.append(f"| {r['gap']} | {r['cell']:g} | {ANSWER.radius / r['cell']:.1f} | "
                     + " | ".join(f"{100 * r[k]:+.1f} %" for k in KEYS)
                     + f" | {order} | {r['rebound']:.3f} | {100 * r['energy']:+.1f} % | "
                     f"{r['particles']:,} | {r['wall_s']:.0f} |")
        previous[r["gap"]] = r
    return lines


def convergence_order(coarse, fine, key):
    """log2 of the error ratio between two refinements by 2."""
    a, b = abs(coarse[key]), abs(fine[key])
    if a == 0 or b == 0:
        return "-"
    return f"{math.log(a / b, coarse['cell'] / fine['cell']):.1f}"


if __name__ == "__main__":
    main()
