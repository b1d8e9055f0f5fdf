"""Two elastic rings colliding, seed 001 Sec. 5.1: total energy history for contact
methods 1 and 2 at several time-step factors (Fig. 4: method 1 shows steep steps before
the rings separate at about 3.4 ms, method 2 stays smooth), whether the rings bounce
apart whole, and when they separate. Writes results/rings/rings.{json,md,png}.

The rings are plane strain (a slab one cell thick between slip faces), 4,392 particles
each; a run of 5 ms takes seconds.

The runs use the case's update order, MUSL, and its linear hats; `--scheme usf` runs
update-stress-first, the paper's order, which is unstable with the hats (see
runs/rings.yaml) and stable with `--shape gimp` or `bspline` (results/rings_usf_gimp/).

Usage: .venv/bin/python scripts/rings.py [--ranks 1] [--methods 1 2] [--cfl 0.1 0.25 0.5 0.8]
       [--scheme musl|usf] [--shape linear|gimp|bspline]
"""
import argparse
import json
import os
import subprocess

from _common import (ROOT, run_case, save_json, pyplot, write_lines, save_figure,
                    method_panels)

from pmpm.post import (body_index, body_points, count_pieces, energy_steps, free_after,
                       min_distance, read_frame, read_history, until_separation)

CASE = "runs/rings.yaml"
SPACING = 1.0            # mm, initial particle spacing
PAPER_SEPARATION = 3.4   # ms, Sec. 5.1


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, default=1)
    parser.add_argument("--methods", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--cfl", type=float, nargs="+", default=[0.1, 0.25, 0.5, 0.8])
    parser.add_argument("--scheme", choices=("musl", "usf"), default="musl")
    parser.add_argument("--shape", choices=("linear", "gimp", "bspline"), default="linear",
                        help="grid.shape_functions (the case's own: linear, as the paper)")
    parser.add_argument("--out", default=None, help="default: results/rings (MUSL) or "
                        "results/rings_usf")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="case override applied to every run, e.g. contact.release=0")
    parser.add_argument("--plot-only", action="store_true", help="re-plot saved results")
    args = parser.parse_args()
    args.out = args.out or os.path.join(ROOT, "results", "rings" + (
        "" if args.scheme == "musl" else f"_{args.scheme}") + (
        "" if args.shape == "linear" else f"_{args.shape}"))
    if args.plot_only:
        with open(os.path.join(args.out, "rings.json"), encoding="utf-8") as f:
            return plot(os.path.join(args.out, "rings.png"), json.load(f), args.out)
    rows = [measure(method, cfl, args) for method in args.methods for cfl in args.cfl]
    save_json(os.path.join(args.out, "rings.json"), rows)
    write_table(os.path.join(args.out, "rings.md"), rows)
    plot(os.path.join(args.out, "rings.png"), rows, args.out)


def run_dir(out, method, cfl):
    return os.path.join(out, f"method{method}_cfl{cfl}")


def measure(method, cfl, args):
    out = run_dir(args.out, method, cfl)
    try:
        summary = run_case(CASE, out, args.ranks,
                           [f"params.method={method}", f"params.cfl={cfl}",
                            f"time.scheme={args.scheme}",
                            f"grid.shape_functions={args.shape}", *args.set])
    except subprocess.CalledProcessError:           # a fault: keep the history up to it
        hist = read_history(out)
        return {"method": method, "cfl": cfl, "failed_at": float(hist["time"][-1]),
                **energy_steps(hist)}
    return {"method": method, "cfl": cfl, "failed_at": None, **ring_measures(out),
            "n_steps": summary["n_steps"],
            "n_particles": summary["n_particles"]["initial"],
            "particles_lost": summary["particles_lost"], "wall_s": summary["wall_s"],
            "particle_steps_per_s": summary["particle_steps_per_s"], "ranks": summary["ranks"]}


def ring_measures(out):
    """Energy smoothness, separation time, final gap, pieces per ring, final velocities."""
    hist = read_history(out)
    frame = read_frame(out)
    left = body_points(frame, body_index(out, "left"))
    right = body_points(frame, body_index(out, "right"))
    contact = energy_steps(until_separation(hist, ("left", "right")))
    return {**energy_steps(hist),
            "contact_drift": contact["drift"], "contact_max_jump": contact["max_jump"],
            "contact_max_excursion": contact["max_excursion"],
            "separation_time": max(free_after(hist, "left"), free_after(hist, "right")),
            "final_gap": min_distance(left, right) - SPACING,
            "pieces": [count_pieces(left, 1.5 * SPACING), count_pieces(right, 1.5 * SPACING)],
            "vx_final": [float(hist["left.vx"][-1]), float(hist["right.vx"][-1])]}


def write_table(path, rows):
    lines = ["| method | cfl | in contact: max jump / K0 | drift / K0 | largest excursion / K0 "
             "| whole run: max jump / K0 | drift / K0 | up-and-down / K0 | separates at (ms) "
             "| final gap (mm) | pieces | vx left, right (m/s) | particles lost | steps | wall s |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if r["failed_at"] is not None:
            lines.append(f"| {r['method']} | {r['cfl']} | | | | {r['max_jump']:.4f} | "
                         f"{r['drift']:+.4f} | {r['variation']:.4f} | run stopped by a fault "
                         f"at t = {r['failed_at']:.3f} ms | | | | | | |")
            continue
        lines.append(
            f"| {r['method']} | {r['cfl']} | {r['contact_max_jump']:.4f} | "
            f"{r['contact_drift']:+.4f} | {r['contact_max_excursion']:.4f} | "
            f"{r['max_jump']:.4f} | {r['drift']:+.4f} | "
            f"{r['variation']:.4f} | {r['separation_time']:.2f} | {r['final_gap']:.1f} | "
            f"{r['pieces'][0]}, {r['pieces'][1]} | {r['vx_final'][0]:.1f}, "
            f"{r['vx_final'][1]:.1f} | {r['particles_lost']} | {r['n_steps']} | "
            f"{r['wall_s']:.0f} |")
    lines.append(f"\nK0: initial kinetic energy. Max jump: largest change of total energy between "
                 f"history rows (5 steps apart). The paper's rings separate at about "
                 f"{PAPER_SEPARATION} ms (they start 4 mm apart here; the paper gives no gap). "
                 f"Final gap: between particle surfaces (centres less one spacing).")
    write_lines(path, lines)


def plot(path, rows, out_dir):
    """Total energy / K0 against time, one panel per method (seed 001 Fig. 4)."""
    plt = pyplot()
    if plt is None:
        return
    fig, panels = method_panels(plt, rows)
    for ax, method, mine in panels:
        for r in mine:
            hist = read_history(run_dir(out_dir, method, r["cfl"]))
            ax.plot(hist["time"], hist["total"] / r["kinetic0"], lw=1, label=f"cfl {r['cfl']}")
        ax.axvline(PAPER_SEPARATION, color="k", ls=":", lw=1, label="paper: separation")
        ax.set_title(f"contact method {method}")
        ax.set_xlabel("t (ms)")
        ax.legend(fontsize=8)
    panels[0][0].set_ylabel("total energy / initial kinetic energy")
    save_figure(fig, path)


if __name__ == "__main__":
    main()
