"""Taylor bar, seed 000 Sec. 5.2: final length L and foot diameter D at cells 0.76 and
0.38 mm (and 0.19 with --fine) against Table 3, wall time and particle count against
Table 4. Writes results/validation/taylor_bar.{json,md,png}.

Usage: .venv/bin/python scripts/taylor_bar.py [--ranks 2] [--fine]
"""
import argparse
import os

from _common import ROOT, run_case, save_json, pyplot, write_lines, save_figure

from pmpm.post import read_frame, taylor_shape

TABLE3 = {0.19: (16.21, 13.28), 0.38: (16.29, 13.14), 0.76: (16.39, 12.68)}
TABLE4 = {0.19: (1342408, 3531, 9488), 0.38: (169376, 1765, 963), 0.76: (21172, 882, 27)}
EXPERIMENT = (16.2, 13.5)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--fine", action="store_true", help="also run 0.19 mm (1.34 M particles)")
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "validation"))
    parser.add_argument("--plot-only", action="store_true", help="re-plot saved results")
    args = parser.parse_args()
    if args.plot_only:
        import json
        with open(os.path.join(args.out, "taylor_bar.json"), encoding="utf-8") as f:
            return plot(os.path.join(args.out, "taylor_bar.png"), json.load(f), args.out)
    cells = [0.76, 0.38] + ([0.19] if args.fine else [])
    rows = [measure(cell, args) for cell in cells]
    save_json(os.path.join(args.out, "taylor_bar.json"), rows)
    write_table(os.path.join(args.out, "taylor_bar.md"), rows)
    plot(os.path.join(args.out, "taylor_bar.png"), rows, args.out)


def measure(cell, args):
    out = os.path.join(args.out, f"taylor_{cell}")
    summary = run_case("runs/taylor_bar.yaml", out, args.ranks, [f"params.cell={cell}"])
    return {"cell": cell, **taylor_shape(read_frame(out)["x"]), "paper_L": TABLE3[cell][0],
            "paper_D": TABLE3[cell][1], "n_particles": summary["n_particles"]["initial"],
            "paper_n_particles": TABLE4[cell][0], "n_steps": summary["n_steps"],
            "paper_steps": TABLE4[cell][1], "wall_s": summary["wall_s"],
            "paper_cpu_s": TABLE4[cell][2], "ranks": summary["ranks"],
            "particle_steps_per_s": summary["particle_steps_per_s"],
            "energy_drift": energy_drift(out)}


def energy_drift(out):
    import numpy as np
    hist = np.genfromtxt(os.path.join(out, "history.csv"), delimiter=",", names=True)
    return float((hist["total"][-1] - hist["total"][0]) / hist["total"][0])


def write_table(path, rows):
    lines = ["| cell (mm) | L pmpm | L Table 3 | D pmpm | D Table 3 | D widest | "
             "particles (Table 4) | steps (Table 4) | wall s, ranks (Table 4 CPU s) | "
             "energy drift |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['cell']} | {r['L']:.2f} | {r['paper_L']} | {r['D']:.2f} | {r['paper_D']} | "
            f"{r['D_widest']:.2f} | "
            f"{r['n_particles']} ({r['paper_n_particles']}) | {r['n_steps']} ({r['paper_steps']}) | "
            f"{r['wall_s']:.0f}, {r['ranks']} ({r['paper_cpu_s']}) | {100 * r['energy_drift']:+.2f} % |")
    lines.append(f"\nExperiment: L = {EXPERIMENT[0]}, D = {EXPERIMENT[1]} mm. L and D from "
                 "particle centres (uncertainty about half a particle spacing): D is the "
                 "footprint's equivalent-circle diameter, D widest twice the largest radius.")
    write_lines(path, lines)


def plot(path, rows, out_dir):
    plt = pyplot()
    if plt is None:
        return
    import numpy as np
    fig, axes = plt.subplots(1, len(rows), figsize=(4 * len(rows), 6), squeeze=False)
    for ax, row in zip(axes[0], rows):
        x = read_frame(os.path.join(out_dir, f"taylor_{row['cell']}"))
        r = np.hypot(x["x"][:, 0], x["x"][:, 1])          # every particle: radius vs height
        sc = ax.scatter(r, x["x"][:, 2], c=x["eps_p"], s=1, cmap="viridis")
        ax.set_title(f"cell {row['cell']} mm: L {row['L']:.2f}, D {row['D']:.2f}")
        ax.set_aspect("equal")
        ax.set_xlabel("r (mm)")
        ax.set_ylabel("z (mm)")
        fig.colorbar(sc, ax=ax, label="eps_p")
    save_figure(fig, path)


if __name__ == "__main__":
    main()
