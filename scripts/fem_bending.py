"""Bending of FEM hexahedra (issue 24): the obstacle cantilever of
tests/cases/obstacle_cantilever.yaml with 3, 2 and 1 elements through its thickness
(params.R = 1, 2, 4), as the `reduced` and the `assumed_strain` element, against beam
theory's first peak; and the cost per element-step of the element kernel
(pmpm.fem.elements.element_forces) of each, interleaved, medians. Writes
results/validation/fem_bending.{json,md}.

Usage: .venv/bin/python scripts/fem_bending.py [--pairs N] [--no-runs]
"""
import argparse
import os
import time

import numpy as np
from _common import ROOT, run_case, save_json, write_lines

from pmpm.post import fsi

ELEMENTS = ("reduced", "assumed_strain")
RATIOS = (1, 2, 4)
#: beam theory's first peak: twice q h^4 / (8 E I), q = rho a b, I = b^3 / 12
RHO, A, B, H, E = 2.5e-3, 0.01, 12.0, 80.0, 1.0
EULER = 2.0 * RHO * A * B * H ** 4 / (8.0 * E * B ** 3 / 12.0)
#: with the shear deflection q h^2 / (2 kappa G b) (kappa 5/6, G = E/2 at nu = 0)
TIMOSHENKO = EULER + 2.0 * RHO * A * B * H ** 2 / (2.0 * 5.0 / 6.0 * 0.5 * E * B)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=7, help="interleaved kernel timings")
    parser.add_argument("--no-runs", action="store_true", help="time the kernel only")
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "validation"))
    args = parser.parse_args()
    rows = [] if args.no_runs else cantilever_rows(args.out)
    cost = kernel_cost(args.pairs)
    save_json(os.path.join(args.out, "fem_bending.json"), {"cantilever": rows,
                                                           "kernel_ns": cost})
    write_table(os.path.join(args.out, "fem_bending.md"), rows, cost)


def cantilever_rows(out_dir):
    rows = []
    for ratio in RATIOS:
        for element in ELEMENTS:
            out = os.path.join(out_dir, f"fem_bending_{ratio}_{element}")
            summary = run_case("tests/cases/obstacle_cantilever.yaml", out, 1,
                               [f"params.R={ratio}", f"bodies[0].fem.element={element}"])
            t, disp = fsi.corner_displacement(out)
            i = int(np.argmax(disp[:, 0]))
            rows.append({"R": ratio, "element": element, "peak": float(disp[i, 0]),
                         "t_peak": float(t[i]), "n_elements": summary["n_elements"],
                         "n_steps": summary["n_steps"]})
    return rows


def box_mesh(n):
    """n^3 unit cubes: node coordinates (.., 3) and hexahedra (n^3, 8) in VTK order."""
    idx = np.arange((n + 1) ** 3).reshape(n + 1, n + 1, n + 1)
    g = np.indices((n + 1, n + 1, n + 1)).reshape(3, -1).T.astype(np.float64)
    i, j, k = np.indices((n, n, n)).reshape(3, -1)
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0),
               (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    hexes = np.stack([idx[i + a, j + b, k + c] for a, b, c in corners], axis=1)
    return g, hexes.astype(np.int64)


def kernel_cost(pairs, n=40, calls=5):
    """Median ns per element of element_forces on n^3 elastic cubes with a random
    velocity field, the reduced (stiffness form) and the assumed_strain element timed
    in turn, ``pairs`` times, each time the best of ``calls`` calls."""
    from pmpm.fem.elements import ElementMesh, Hourglass, element_forces
    from pmpm.fem.stability import ASSUMED_STRAIN, STIFFNESS
    from pmpm.kernels.records import BodyMaterials
    from pmpm.materials import layout
    from pmpm.materials.state import MaterialState
    x, hexes = box_mesh(n)
    m = len(hexes)
    v = 1e-3 * np.random.default_rng(0).normal(size=x.shape)
    mesh = ElementMesh(x, v, hexes, np.zeros(m, np.int32))
    prm = np.zeros((1, layout.N_SLOTS))
    prm[0, [layout.RHO0, layout.E, layout.NU, layout.G, layout.K]] = [5e-3, 1e5, 0.25,
                                                                       4e4, 1e5 / 1.5]
    materials = BodyMaterials(np.array([layout.ELASTIC], np.int64), prm,
                              np.zeros(1, np.bool_))
    times = {STIFFNESS: [], ASSUMED_STRAIN: []}
    for _ in range(pairs):
        for kind in times:
            state = MaterialState(np.zeros((m, 6)), np.tile(np.eye(3).ravel(), (m, 1)),
                                  np.full(m, 5e-3), np.zeros(m), np.zeros(m), np.zeros(m),
                                  np.zeros(m), np.zeros(m), np.zeros(m))
            hg = Hourglass(np.array([kind], np.int64), np.array([0.05]), np.zeros((m, 12)),
                           np.zeros(m))
            force = np.zeros_like(x)
            best = np.inf
            for _ in range(calls):
                start = time.perf_counter()
                element_forces(mesh, state, materials, hg, 1e-6, force)
                best = min(best, time.perf_counter() - start)
            times[kind].append(1e9 * best / m)
    return {"reduced": times[STIFFNESS], "assumed_strain": times[ASSUMED_STRAIN],
            "elements": m}


def write_table(path, rows, cost):
    lines = [f"Beam theory's first peak {EULER:.2f} mm (with the shear deflection "
             f"{TIMOSHENKO:.2f} mm).", "",
             "| elements (thickness x height) | element | first peak (mm) | / beam theory "
             "| t (ms) | steps |", "|---|---|---|---|---|---|"]
    for r in rows:
        across = {1: "3 x 20", 2: "2 x 10", 4: "1 x 5"}[r["R"]]
        lines.append(f"| {across} | {r['element']} | {r['peak']:.2f} | "
                     f"{r['peak'] / EULER:.3f} | {r['t_peak']:.0f} | {r['n_steps']} |")
    red, ass = np.median(cost["reduced"]), np.median(cost["assumed_strain"])
    lines += ["", f"element_forces, {cost['elements']} elastic elements, ns per element "
                  f"(median of {len(cost['reduced'])} interleaved pairs): reduced "
                  f"{red:.0f}, assumed_strain {ass:.0f} ({ass / red:.2f} times)"]
    write_lines(path, lines, echo=True)


if __name__ == "__main__":
    main()
