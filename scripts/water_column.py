"""Water column on an elastic obstacle (seed 004 Sec. 4.3, Figs. 11-12): runs/water_column.yaml
with surface coupling (ICFEMP) at R = 1, 2, 4 and grid coupling (CFEMP) at R = 1; the
obstacle's upper-left corner displacement in time, the free surface and obstacle at the
figure times, and a table (largest displacement, water particles inside the obstacle,
cost).

    python scripts/water_column.py --out results/water_column               # c0 = 50 m/s
    python scripts/water_column.py --c0 1647 --end 5 --variants icfemp_R1   # cost of the real c0
    python scripts/water_column.py --cell 8 --variants icfemp_R1 cfemp_R1   # coarse

Writes OUT/<variant>/ (each run), OUT/table.md, OUT/corner.png, OUT/surface.png.
The seed gives neither the figure times nor numbers (figures only): the free surface is
drawn at 0.1 ... 0.5 s, and ICFEMP is checked against CFEMP at R = 1 and against itself
over R.
"""
import argparse
import os

import numpy as np

from _common import pyplot, run_case, save_figure, write_lines
from pmpm.post import fsi
from pmpm.post.frames import frame_times, read_frame

CASE = "runs/water_column.yaml"
WATER = 1                                 # body id of the water (second body)
#: variant: its --set items
VARIANTS = {"icfemp_R1": ["params.R=1"],
            "icfemp_R2": ["params.R=2"],
            "icfemp_R4": ["params.R=4"],
            "cfemp_R1": ["params.R=1", "contact.coupling=grid", "params.method=1"]}
SNAPSHOTS = [100.0, 200.0, 300.0, 400.0, 500.0]      # ms


def run_variant(name, args):
    out = os.path.join(args.out, name)
    snapshots = [t for t in SNAPSHOTS if t <= args.end]
    sets = VARIANTS[name] + [f"params.c0={args.c0}", f"params.cell={args.cell}",
                             f"params.ppc={args.ppc}",
                             f"time.end={args.end}", f"output.times={snapshots}"] + args.set
    summary = run_case(CASE, out, ranks=args.ranks, sets=sets)
    times, disp = fsi.corner_displacement(out)
    frames = range(len(frame_times(out)))
    inside = [fsi.particles_inside(out, WATER, index=i)[1] for i in frames]
    margin = args.cell / args.ppc / 4
    deep = [fsi.particles_inside(out, WATER, margin=margin, index=i)[1] for i in frames]
    return {"name": name, "out": out, "t": times, "dx": disp[:, 0], "dy": disp[:, 1],
            "inside": max(inside), "deep": max(deep), "steps": summary["n_steps"],
            "wall": summary["wall_s"], "rate": summary["particle_steps_per_s"],
            "lost": summary["particles_lost"]}


def table(rows):
    lines = ["| variant | largest dx (mm) | at t (ms) | dx at end (mm) | water particle "
             "centres inside (most in a frame: any depth, deeper than 1/4 spacing) | steps | "
             "wall (s) | particle-steps/s | lost |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        k = int(np.argmax(r["dx"]))
        lines.append(f"| {r['name']} | {r['dx'][k]:.2f} | {r['t'][k]:.0f} | {r['dx'][-1]:.2f} "
                     f"| {r['inside']}, {r['deep']} | {r['steps']} | {r['wall']:.0f} | "
                     f"{r['rate']:.3g} | {r['lost']} |")
    if len(rows) > 1:
        base = rows[0]
        for r in rows[1:]:
            if np.array_equal(r["t"], base["t"]):
                diff = np.abs(r["dx"] - base["dx"]).max()
                lines.append(f"\nlargest |dx({r['name']}) - dx({base['name']})| over the "
                             f"frames: {diff:.2f} mm")
    return lines


def plot_corner(plt, rows, path):
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for r in rows:
        ax.plot(r["t"] / 1000.0, r["dx"], label=r["name"])
    ax.set_xlabel("t (s)")
    ax.set_ylabel("upper-left corner displacement x (mm)")
    ax.legend()
    ax.grid(alpha=0.3)
    save_figure(fig, path)


def plot_surface(plt, rows, path):
    fig, axes = plt.subplots(len(rows), len(SNAPSHOTS), figsize=(3 * len(SNAPSHOTS),
                             2.6 * len(rows)), squeeze=False, sharex=True, sharey=True)
    for row_axes, r in zip(axes, rows):
        times = frame_times(r["out"])
        node_t, node_x, hexes = fsi.node_paths(r["out"])
        for ax, target in zip(row_axes, SNAPSHOTS):
            i = int(np.argmin(np.abs(np.array(times) - target)))
            if abs(times[i] - target) > 1e-6:
                ax.set_axis_off()
                continue
            frame = read_frame(r["out"], i)
            water = frame["x"][frame["body"] == WATER]
            ax.scatter(water[:, 0], water[:, 1], s=0.3, c="tab:blue")
            k = int(np.argmin(np.abs(node_t - target)))
            for quad in fsi.element_quads(node_x[k], hexes):
                ax.fill(quad[:, 0], quad[:, 1], color="tab:red", lw=0)
            ax.set_title(f"{r['name']}, t = {target / 1000:.1f} s", fontsize=8)
            ax.set_aspect("equal")
    save_figure(fig, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/water_column")
    parser.add_argument("--variants", nargs="+", choices=list(VARIANTS),
                        default=list(VARIANTS))
    parser.add_argument("--c0", type=float, default=50.0, help="water sound speed (m/s)")
    parser.add_argument("--cell", type=float, default=4.0, help="cell edge (mm)")
    parser.add_argument("--ppc", type=int, default=2, help="particles per cell per direction")
    parser.add_argument("--end", type=float, default=500.0, help="end time (ms)")
    parser.add_argument("--set", action="append", default=[], help="passed to pmpm")
    parser.add_argument("--ranks", type=int, default=1)
    args = parser.parse_args()
    rows = [run_variant(name, args) for name in args.variants]
    write_lines(os.path.join(args.out, "table.md"), table(rows), echo=True)
    plt = pyplot()
    if plt:
        plot_corner(plt, rows, os.path.join(args.out, "corner.png"))
        plot_surface(plt, rows, os.path.join(args.out, "surface.png"))


if __name__ == "__main__":
    main()
