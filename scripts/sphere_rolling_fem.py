"""The element-size sweep of seed 004 Sec. 4.1 (Table 1): runs/sphere_rolling_fem.yaml at
R = 1, 2, 4, 8 (element size / cell) for mu = 0.2 (slides) and 0.4 (rolls), with surface
coupling (ICFEMP) and grid coupling (CFEMP), and a table of the sphere's travel at the
end against Eq. 55 and the seed's two columns.

    python scripts/sphere_rolling_fem.py --out results/sphere_rolling_fem
    python scripts/sphere_rolling_fem.py --coupling grid --R 4 8           # CFEMP only
    python scripts/sphere_rolling_fem.py --R 2 --mu 0.4 --set time.end=500   # one, short

CFEMP runs as the grid coupling wants it (pmpm/solver/fem_grid.py): contact method 1,
gimp shape functions (the plate's nodes sit on grid nodes) and the plate's own normal
for the pair (GRID_SETS).

Writes OUT/R{R}_mu{mu}/ (ICFEMP) and OUT/cfemp_R{R}_mu{mu}/ (CFEMP), each run's
outputs, and OUT/table.md; prints the table.
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CASE = os.path.join(os.path.dirname(HERE), "runs", "sphere_rolling_fem.yaml")
THETA, G, X0 = math.pi / 4, 10.0, 2000.0          # rad, m/s^2, mm
#: seed 004 Table 1, x at 2 s (m) per coupling and (mu, R)
SEED = {"surface": {(0.2, 1): 11.8, (0.2, 2): 11.9, (0.2, 4): 11.9, (0.2, 8): 11.9,
                    (0.4, 1): 10.7, (0.4, 2): 10.7, (0.4, 4): 10.7, (0.4, 8): 10.7},
        "grid": {(0.2, 1): 11.6, (0.2, 2): 11.9, (0.2, 4): 9.6, (0.2, 8): 14.4,
                 (0.4, 1): 10.2, (0.4, 2): 10.0, (0.4, 4): 9.0, (0.4, 8): 14.0}}
#: the --set items that turn the case into CFEMP
GRID_SETS = ["contact.coupling=grid", "params.method=1", "grid.shape_functions=gimp",
             "contact.pairs=[{bodies: [plate, sphere], normal: plate}]"]
NAMES = {"surface": "ICFEMP", "grid": "CFEMP"}


def eq55(t, mu, theta=THETA, g=G):
    """The rigid sphere's travel (m) at t (s): sliding when tan(theta) > 3.5 mu, else
    rolling without slip."""
    if math.tan(theta) > 3.5 * mu:
        return 0.5 * g * t * t * (math.sin(theta) - mu * math.cos(theta))
    return 5.0 / 14.0 * g * t * t * math.sin(theta)


def run(R, mu, coupling, out, extra, ranks):
    """Run one case; (travel x (m) at the last history row, its time (s), wall s)."""
    cmd = [sys.executable, "-m", "pmpm", CASE, "--out", out, "--force", "--quiet",
           "--set", f"params.R={R}", "--set", f"params.mu={mu}"]
    for item in (GRID_SETS if coupling == "grid" else []) + extra:
        cmd += ["--set", item]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe"] + cmd
    start = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"R = {R}, mu = {mu}: the run failed:\n{done.stderr[-2000:]}")
    with open(os.path.join(out, "history.csv")) as handle:
        last = list(csv.DictReader(handle))[-1]
    return (float(last["sphere.x"]) - X0) / 1000.0, float(last["time"]) / 1000.0, wall


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/sphere_rolling_fem")
    parser.add_argument("--R", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--mu", type=float, nargs="+", default=[0.2, 0.4])
    parser.add_argument("--set", action="append", default=[], help="passed to pmpm")
    parser.add_argument("--ranks", type=int, default=1)
    parser.add_argument("--coupling", nargs="+", choices=["surface", "grid"],
                        default=["surface", "grid"], help="surface: ICFEMP, grid: CFEMP")
    args = parser.parse_args()
    rows = ["| coupling | mu | R | t (s) | x (m) | Eq. 55 (m) | error | seed (m) | wall (s) |",
            "|---|---|---|---|---|---|---|---|---|"]
    for coupling in args.coupling:
        for mu in args.mu:
            for R in args.R:
                prefix = "cfemp_" if coupling == "grid" else ""
                out = os.path.join(args.out, f"{prefix}R{R}_mu{mu:g}")
                x, t, wall = run(R, mu, coupling, out, args.set, args.ranks)
                exact = eq55(t, mu)
                seed = SEED[coupling].get((mu, R)) if abs(t - 2.0) < 1e-9 else None
                rows.append(f"| {NAMES[coupling]} | {mu:g} | {R} | {t:.3f} | {x:.3f} | "
                            f"{exact:.3f} | {100 * (x / exact - 1):+.1f} % | "
                            f"{seed if seed else '-'} | {wall:.0f} |")
                print(rows[-1], flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "table.md"), "w") as handle:
        handle.write("\n".join(rows) + "\n")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
