"""Elastic wave in a 100 mm bar, seed 000 Sec. 5.1: sigma_xx along the bar against the 1D
solution at 7.6, 15.6 and 41.6 us for uniform cells of 0.25, 0.5, 0.75 and 1 mm, and the
RMS error (normalised by the load stress) beside Table 1's MPM column. Writes
results/validation/wave_bar.{json,md,png}.

The long faces are slip faces, so the bar is one-dimensional whatever its width; by
default it is two cells wide (fast). --width 6 runs the paper's 6 x 6 mm section.

Usage: .venv/bin/python scripts/wave_bar.py [--ranks 2] [--width MM]
"""
import argparse
import os

import numpy as np
from _common import ROOT, run_case, save_json, pyplot, write_lines, save_figure

from pmpm.post import axial_profiles, rms_error, wave_bar_stress

C = np.sqrt(1.0e5 / 5.0e-3)
LOAD = -2.5 / 36.0
TIMES = (0.0076, 0.0156, 0.0416)
TABLE1_MPM = {0.25: 64e-4, 0.5: 71e-4, 0.75: 79e-4, 1.0: 87e-4}     # "RMS error", unit not given


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, default=2)
    parser.add_argument("--width", type=float, default=None, help="section edge (mm)")
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "validation"))
    args = parser.parse_args()
    rows, profiles = [], {}
    for cell in (1.0, 0.75, 0.5, 0.25):
        out = os.path.join(args.out, f"wave_{cell}")
        width = args.width or 2 * cell
        summary = run_case("runs/wave_bar.yaml", out, args.ranks,
                           [f"params.cell={cell}", f"params.width={width}"])
        profiles[cell] = read_profiles(out)
        rows.append(row(cell, width, summary, profiles[cell]))
    save_json(os.path.join(args.out, "wave_bar.json"), rows)
    write_table(os.path.join(args.out, "wave_bar.md"), rows)
    plot(os.path.join(args.out, "wave_bar.png"), profiles)


def read_profiles(out):
    return axial_profiles(out, TIMES)


def row(cell, width, summary, prof):
    errors = {f"{1e3 * t:.1f}us": rms_error(s, wave_bar_stress(x, t, 100.0, C, LOAD), LOAD)
              for t, (x, s) in prof.items()}
    return {"cell": cell, "width": width, "rms_over_load": errors,
            "table1_mpm": TABLE1_MPM[cell],
            "table1_mpm_over_load_if_MPa": TABLE1_MPM[cell] / abs(LOAD),
            "n_particles": summary["n_particles"]["initial"], "n_steps": summary["n_steps"],
            "wall_s": summary["wall_s"]}


def write_table(path, rows):
    lines = ["| cell (mm) | RMS/load 7.6 us | 15.6 us | 41.6 us | Table 1 MPM (x1e-4) | "
             "Table 1 / load, if in MPa |", "|---|---|---|---|---|---|"]
    for r in rows:
        e = r["rms_over_load"]
        lines.append(f"| {r['cell']} | {e['7.6us']:.4f} | {e['15.6us']:.4f} | {e['41.6us']:.4f} "
                     f"| {1e4 * r['table1_mpm']:.0f} | {r['table1_mpm_over_load_if_MPa']:.4f} |")
    lines.append("\nTable 1 does not state its unit or time; read as MPa it normalises to the "
                 "last column.")
    write_lines(path, lines)


def plot(path, profiles, label="cell {} mm"):
    """sigma_xx / load along the bar at TIMES against the 1D solution; ``profiles`` maps
    a size to {time: (x, sigma_xx)}, ``label`` formats a size (also scripts/fem_wave_bar.py)."""
    plt = pyplot()
    if plt is None:
        return
    fig, axes = plt.subplots(len(TIMES), 1, figsize=(9, 9), sharex=True)
    for ax, t in zip(axes, TIMES):
        xs = np.linspace(0, 100, 2001)
        ax.plot(xs, wave_bar_stress(xs, t, 100.0, C, LOAD) / LOAD, "k-", lw=2, label="1D theory")
        for size, prof in profiles.items():
            x, s = prof[t]
            ax.plot(x, s / LOAD, lw=1, label=label.format(size))
        ax.set_ylabel("sigma_xx / load")
        ax.set_title(f"t = {1e3 * t:.1f} us")
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("x (mm)")
    save_figure(fig, path)

if __name__ == "__main__":
    main()
