"""Tied interface grid MPM, seed 000 Sec. 5: every case run with a refined window beside
the uniform grids it is compared with. Writes results/validation/tied_<case>.{json,md,png}.

- wave:   the 100 mm bar of Sec. 5.1, loaded 40 mm refined at 0.25 mm, R = 1..4 beside
          uniform 0.25, 0.5, 0.75 and 1 mm: RMS error / load stress at 7.6, 15.6 and
          41.6 us (Table 1; length-weighted RMS, since window particles are smaller).
- taylor: the Taylor bar of Sec. 5.2 with 0.19 mm over the bottom 11.4 mm, R = 2 and 4,
          beside uniform 0.38 (and 0.19 with --fine): L, D (Table 3), particles, steps,
          wall time (Table 4).
- ball:   the steel sphere on the 1 mm plate (Sec. 5.3), 0.5 mm window around the ball,
          1 mm outside, beside uniform 0.5 mm (with --fine) and 1 mm: h/D, V_r, cost
          (Table 6).
- ogive:  the ogive rod through the 26.3 mm A6061 plate at 30 deg (Sec. 5.4), a 1 mm
          window over the whole rod following it (rod and plate at 0.5 mm there), 2 mm
          outside, beside uniform 2 mm: residual speed (Table 9) and cost (Table 10).

Usage: .venv/bin/python scripts/tied_grid.py wave|taylor|ball|ogive [--ranks 2] [--fine]
"""
import argparse
import os

import numpy as np
from _common import ROOT, run_case, save_json, pyplot, write_lines, save_figure

from pmpm.post import (axial_profiles, body_index, body_points, perforation, read_frame,
                       read_history, residual_velocity, rms_error,
                       taylor_shape, wave_bar_stress)

OUT = os.path.join(ROOT, "results", "validation")


# ---------------------------------------------------------------- wave bar (Sec. 5.1)

C, LOAD, TIMES = np.sqrt(1.0e5 / 5.0e-3), -2.5 / 36.0, (0.0076, 0.0156, 0.0416)
TABLE1 = {("tied", 1): 64, ("tied", 2): 68, ("tied", 3): 73, ("tied", 4): 79,
          ("uniform", 1): 64, ("uniform", 2): 71, ("uniform", 3): 79, ("uniform", 4): 87}


def wave(args):
    rows = []
    for kind in ("uniform", "tied"):
        for r in (1, 2, 3, 4):
            cell = 0.25 * r
            ratio = r if kind == "tied" else 1
            out = os.path.join(args.out, f"tied_wave_{kind}_R{r}")
            summary = run_case("runs/wave_bar.yaml", out, args.ranks,
                               [f"params.cell={cell}", f"params.ratio={ratio}",
                                f"params.width={cell}"])
            prof = axial_profiles(out, TIMES, volumes=True)
            errors = [rms_error(s, wave_bar_stress(x, t, 100.0, C, LOAD), LOAD, w)
                      for t, (x, s, w) in sorted(prof.items())]
            rows.append({"kind": kind, "R": r, "coarse_cell": cell, "window_cell":
                         cell / ratio, "rms_over_load": errors,
                         "table1_x1e4": TABLE1[(kind, r)],
                         "n_particles": summary["n_particles"]["initial"],
                         "n_steps": summary["n_steps"], "wall_s": summary["wall_s"],
                         "out": out})
    save_json(os.path.join(args.out, "tied_wave.json"), rows)
    lines = ["| grid | R | RMS/load 7.6 us | 15.6 us | 41.6 us | Table 1 (x1e-4) |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        name = (f"TIGMPM 0.25 / {r['coarse_cell']:g}" if r["kind"] == "tied"
                else f"MPM {r['coarse_cell']:g}")
        e = r["rms_over_load"]
        lines.append(f"| {name} | {r['R']} | {e[0]:.4f} | {e[1]:.4f} | {e[2]:.4f} | "
                     f"{r['table1_x1e4']} |")
    write_lines(os.path.join(args.out, "tied_wave.md"), lines, echo=True)
    plot_wave(os.path.join(args.out, "tied_wave.png"), rows)


def plot_wave(path, rows):
    plt = pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    for ax, t in zip(axes, TIMES):
        for r in rows:
            x, s = axial_profiles(r["out"], (t,))[t]
            label = f"{'TIG' if r['kind'] == 'tied' else 'MPM'} R={r['R']}"
            ax.plot(x, s / LOAD, lw=0.8, label=label,
                    ls="-" if r["kind"] == "tied" else ":")
        xs = np.linspace(0, 100, 801)
        ax.plot(xs, wave_bar_stress(xs, t, 100.0, C, LOAD) / LOAD, "k", lw=1.2, label="1D")
        ax.axvline(60.0, color="grey", lw=0.5)
        ax.set_title(f"t = {t * 1e3:.1f} us")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("sigma_xx / load")
    axes[0].legend(fontsize=6)
    save_figure(fig, path)


# ---------------------------------------------------------------- Taylor bar (Sec. 5.2)

TABLE3 = {"MPM 0.19": (16.21, 13.28), "MPM 0.38": (16.29, 13.14), "MPM 0.76": (16.39, 12.68),
          "TIG R=2": (16.29, 13.28), "TIG R=4": (16.29, 13.24)}
TABLE4 = {"MPM 0.19": (1342408, 3531, 9488), "MPM 0.38": (169376, 1765, 963),
          "MPM 0.76": (21172, 882, 27), "TIG R=2": (696416, 3530, 5158),
          "TIG R=4": (614572, 3532, 3767)}


def taylor(args):
    runs = {"TIG R=2": (0.38, 2), "TIG R=4": (0.76, 4), "MPM 0.38": (0.38, 1)}
    if args.fine:
        runs["MPM 0.19"] = (0.19, 1)
    rows = []
    for name, (cell, ratio) in runs.items():
        out = os.path.join(args.out, "tied_taylor_" + name.replace(" ", "_").replace("=", ""))
        summary = run_case("runs/taylor_bar.yaml", out, args.ranks,
                           [f"params.cell={cell}", f"params.ratio={ratio}"])
        hist = read_history(out)
        rows.append({"run": name, **taylor_shape(read_frame(out)["x"]),
                     "paper_L": TABLE3[name][0],
                     "paper_D": TABLE3[name][1], **cost(summary),
                     "paper_n_particles": TABLE4[name][0], "paper_steps": TABLE4[name][1],
                     "paper_cpu_s": TABLE4[name][2],
                     "energy_drift": float((hist["total"][-1] - hist["total"][0])
                                           / hist["total"][0])})
    save_json(os.path.join(args.out, "tied_taylor.json"), rows)
    lines = ["| run | L (Table 3) | D (Table 3) | D widest | particles initial -> final "
             "(Table 4) | steps (Table 4) | wall s on ranks (Table 4 CPU s) | energy drift |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['run']} | {r['L']:.2f} ({r['paper_L']}) | {r['D']:.2f} "
                     f"({r['paper_D']}) | {r['D_widest']:.2f} | {r['n_initial']} -> "
                     f"{r['n_final']} "
                     f"({r['paper_n_particles']}) | {r['n_steps']} ({r['paper_steps']}) | "
                     f"{r['wall_s']:.0f} on {r['ranks']} ({r['paper_cpu_s']}) | "
                     f"{100 * r['energy_drift']:+.2f} % |")
    lines.append("\nExperiment: L = 16.2, D = 13.5 mm; L and D from particle centres (D: "
                 "the footprint's equivalent circle; D widest: twice the largest radius).")
    write_lines(os.path.join(args.out, "tied_taylor.md"), lines, echo=True)


def cost(summary):
    return {"n_initial": summary["n_particles"]["initial"],
            "n_final": summary["n_particles"]["final"], "n_steps": summary["n_steps"],
            "wall_s": summary["wall_s"], "ranks": summary["ranks"],
            "particle_steps_per_s": summary["particle_steps_per_s"]}


# ---------------------------------------------------------------- steel ball (Sec. 5.3)

def ball(args):
    runs = {"TIG 0.5/1": (1.0, 2), "MPM 1": (1.0, 1)}
    if args.fine:
        runs["MPM 0.5"] = (0.5, 1)
    paper = {"MPM 0.5": (0.85, 404344, 6737, 12314), "TIG 0.5/1": (0.85, 201074, 6737, 4875)}
    rows = []
    for name, (cell, ratio) in runs.items():
        out = os.path.join(args.out, "tied_ball_" + name.replace(" ", "_").replace("/", "_"))
        summary = run_case("runs/steel_ball_plate.yaml", out, args.ranks,
                           [f"params.cell={cell}", f"params.ratio={ratio}"])
        plate = body_points(read_frame(out), body_index(out, "plate"))
        spacing = cell / ratio / 2
        measure = perforation(plate, spacing, axis=2, thickness=1.0)
        v_r = -read_history(out)["ball.vz"][-1]
        ref = paper.get(name, (None,) * 4)
        rows.append({"run": name, "h_over_D": measure["h_over_D"], "D": measure["D"],
                     "h": measure["h"], "perforated": measure["perforated"], "V_r": v_r,
                     **cost(summary), "paper_h_over_D": ref[0], "paper_n": ref[1],
                     "paper_steps": ref[2], "paper_cpu_s": ref[3]})
    save_json(os.path.join(args.out, "tied_ball.json"), rows)
    lines = ["| run | h/D (Table 6) | V_r m/s | particles (Table 6) | steps (Table 6) | "
             "wall s on ranks (Table 6 CPU s) |", "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['run']} | {r['h_over_D']:.2f} ({r['paper_h_over_D']}) | "
                     f"{r['V_r']:.1f} | {r['n_initial']} -> {r['n_final']} ({r['paper_n']}) | "
                     f"{r['n_steps']} ({r['paper_steps']}) | {r['wall_s']:.0f} on "
                     f"{r['ranks']} ({r['paper_cpu_s']}) |")
    lines.append("\nExperiment: h/D = 0.84.")
    write_lines(os.path.join(args.out, "tied_ball.md"), lines, echo=True)


# ---------------------------------------------------------------- ogive rod (Sec. 5.4)

TABLE9 = {446: (288, 299, 306), 575: (455, 470, 471), 730: (655, 651, 652)}
TABLE10 = {446: (7652, 7679, 119, 467), 575: (5879, 5885, 95, 391), 730: (4228, 4227, 68, 258)}


def ogive(args):
    rows = []
    for v0 in args.speeds:
        for name, ratio, ppc_rod in (("MPM 2", 1, 3), ("TIG 1/2", 2, 2)):
            out = os.path.join(args.out, f"tied_ogive_{v0}_" + name.split()[0])
            summary = run_case("runs/ogive_plate.yaml", out, args.ranks,
                               [f"params.v0={v0}", f"params.ratio={ratio}",
                                f"params.ppc_rod={ppc_rod}"])
            v_r = residual_velocity(read_history(out), "rod")
            exp, tig, mpm = TABLE9.get(v0, (None,) * 3)
            rows.append({"run": name, "v0": v0, "V_r": v_r, "experiment": exp,
                         "paper": tig if ratio > 1 else mpm, **cost(summary)})
    save_json(os.path.join(args.out, "tied_ogive.json"), rows)
    lines = ["| v0 | run | V_r pmpm | V_r paper (experiment) | particles | steps | "
             "wall s on ranks |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['v0']} | {r['run']} | {r['V_r']:.0f} | {r['paper']} "
                     f"({r['experiment']}) | {r['n_initial']} -> {r['n_final']} | "
                     f"{r['n_steps']} | {r['wall_s']:.0f} on {r['ranks']} |")
    write_lines(os.path.join(args.out, "tied_ogive.md"), lines, echo=True)


# ---------------------------------------------------------------- helpers

def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=("wave", "taylor", "ball", "ogive"))
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--fine", action="store_true",
                        help="also run the uniform fine grid (Taylor 0.19, ball 0.5 mm)")
    parser.add_argument("--speeds", type=int, nargs="+", default=[575],
                        help="ogive striking speeds (m/s; Table 9: 446 575 730)")
    parser.add_argument("--out", default=OUT)
    args = parser.parse_args()
    {"wave": wave, "taylor": taylor, "ball": ball, "ogive": ogive}[args.case](args)


if __name__ == "__main__":
    main()
