"""Elastic wave in a 100 mm bar (seed 000 Sec. 5.1) as one FEM body: sigma_xx at the
element centroids against the 1D solution at 7.6, 15.6 and 41.6 us for elements of 1,
0.5 and 0.25 mm, beside the MPM bar (runs/wave_bar.yaml) at the same cell size, run by
this script too. Writes results/validation/fem_wave_bar.{json,md,png}.

The long faces are slip faces, so the bar is one-dimensional whatever its width; by
default it is one element (FEM) or two cells (MPM) wide. Both run on one rank.

Usage: .venv/bin/python scripts/fem_wave_bar.py [--width MM] [--no-mpm]
"""
import argparse
import os

from _common import ROOT, run_case, save_json, write_lines
import wave_bar

from pmpm.post import axial_profiles, element_profiles, rms_error, wave_bar_stress

C, LOAD, TIMES = wave_bar.C, wave_bar.LOAD, wave_bar.TIMES
SIZES = (1.0, 0.5, 0.25)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--width", type=float, default=None, help="section edge (mm)")
    parser.add_argument("--no-mpm", action="store_true", help="skip the MPM bar")
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "validation"))
    args = parser.parse_args()
    rows, profiles = [], {}
    for size in SIZES:
        out = os.path.join(args.out, f"fem_wave_{size}")
        width = args.width or size
        summary = run_case("runs/fem_wave_bar.yaml", out, 1,
                           [f"params.element={size}", f"params.width={width}"])
        profiles[size] = element_profiles(out, TIMES)
        rows.append({"element": size, "width": width, "fem": errors(profiles[size]),
                     "n_elements": summary["n_elements"], "n_steps": summary["n_steps"],
                     "wall_s": summary["wall_s"],
                     "element_steps_per_s": summary["element_steps_per_s"],
                     "mpm": None if args.no_mpm else mpm_errors(args, size)})
    save_json(os.path.join(args.out, "fem_wave_bar.json"), rows)
    write_table(os.path.join(args.out, "fem_wave_bar.md"), rows)
    plot(os.path.join(args.out, "fem_wave_bar.png"), profiles)


def errors(profiles):
    return {f"{1e3 * t:.1f}us": rms_error(s, wave_bar_stress(x, t, 100.0, C, LOAD), LOAD)
            for t, (x, s) in profiles.items()}


def mpm_errors(args, cell):
    out = os.path.join(args.out, f"fem_wave_mpm_{cell}")
    run_case("runs/wave_bar.yaml", out, 1,
             [f"params.cell={cell}", f"params.width={args.width or 2 * cell}"])
    return errors(axial_profiles(out, TIMES))


def write_table(path, rows):
    lines = ["| element = cell (mm) | FEM 7.6 us | 15.6 us | 41.6 us | MPM 7.6 us | 15.6 us "
             "| 41.6 us | elements | steps |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        f, m = r["fem"], r["mpm"] or {}
        mpm = [f"{m[k]:.4f}" if k in m else "-" for k in ("7.6us", "15.6us", "41.6us")]
        lines.append(f"| {r['element']} | {f['7.6us']:.4f} | {f['15.6us']:.4f} | "
                     f"{f['41.6us']:.4f} | {' | '.join(mpm)} | {r['n_elements']} | "
                     f"{r['n_steps']} |")
    lines.append("\nRMS error of sigma_xx against the 1D solution divided by the load "
                 "stress; FEM at the element centroids, MPM at the particles.")
    write_lines(path, lines, echo=True)


def plot(path, profiles):
    wave_bar.plot(path, profiles, label="FEM {} mm")

if __name__ == "__main__":
    main()
