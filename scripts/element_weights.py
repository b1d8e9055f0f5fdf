"""What an element-step costs against a particle-step, for the slabs' balance (issue 24).

One rank, the same copper block (Johnson-Cook + Mie-Grueneisen + bulk viscosity, 190 m/s
onto a slip wall) as 125,000 particles (runs/bench_block.yaml, edge 25 mm, 2 particles
per 1 mm cell per direction) with each shape function, and as 125,000 hexahedra of
0.5 mm (runs/fem_block.yaml, edge 25 mm) with each element formulation, plus the block
as a rigid FEM body (no element stress update: pmpm.fem.elements skips rigid bodies)
moving sideways at a fixed step. The variants run interleaved (all once, then all
again), ``--repeat`` times; the page gives medians of the seconds per point-step (the
run's stepping wall time over its particle- or element-steps) and the ratios
element / particle that pmpm.solver.work_weights tabulates.

Writes results/element_weights/weights.{json,md}.

Usage: .venv/bin/python scripts/element_weights.py [--repeat 3] [--edge 25] [--merge JSON]
"""
import argparse
import json
import os
import statistics

from _common import ROOT, run_case, save_json, write_lines

BLOCK = "runs/bench_block.yaml"
FEM_BLOCK = "runs/fem_block.yaml"
PARTICLES = {shape: [f"grid.shape_functions={shape}"] for shape in ("linear", "gimp",
                                                                    "bspline")}
ELEMENTS = {
    "reduced_viscous": ["bodies.0.fem={element_size: 0.5, hourglass: viscous}"],
    "reduced_stiffness": ["bodies.0.fem={element_size: 0.5, hourglass: stiffness}"],
    "assumed_strain": ["bodies.0.fem={element_size: 0.5, element: assumed_strain}"],
    # a rigid body has no wave speed: the step is fixed at the elastic block's (about
    # 6e-5 ms at 0.5 mm), and it flies along x so that no node meets the slip floor
    "rigid": ["materials.copper={model: rigid, density: 8.93e-3}",
              "bodies.0.velocity=[190, 0, 0]", "time.dt=6e-5"],
}


def variants(edge):
    common = [f"params.edge={edge}", "output.frames=1"]
    out = {f"particles_{k}": (BLOCK, common + v) for k, v in PARTICLES.items()}
    out.update({f"elements_{k}": (FEM_BLOCK, common + ["params.element=0.5"] + v)
                for k, v in ELEMENTS.items()})
    return out


def seconds_per_step(summary):
    """Seconds of stepping per particle-step (per element-step for an FEM-only run)."""
    if summary["n_particles"]["initial"]:
        return 1.0 / summary["particle_steps_per_s"]
    return 1.0 / summary["element_steps_per_s"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--edge", type=float, default=25.0)
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "element_weights"))
    parser.add_argument("--merge", metavar="JSON", help="an earlier weights.json of the same "
                        "variants: its samples join this run's (more repeats in two sittings)")
    args = parser.parse_args()
    cases = variants(args.edge)
    samples = {name: [] for name in cases}
    if args.merge:
        with open(args.merge, encoding="utf-8") as f:
            samples = {name: list(v) for name, v in json.load(f)["samples_s"].items()}
    for repeat in range(args.repeat):
        for name, (case, sets) in cases.items():
            s = run_case(case, os.path.join(args.out, name), 1, sets)
            samples[name].append(seconds_per_step(s))
            print(f"{name} repeat {repeat}: {1e6 * samples[name][-1]:.3f} us/point-step",
                  flush=True)
    medians = {name: statistics.median(v) for name, v in samples.items()}
    ratios = {e: {p: medians[f"elements_{e}"] / medians[f"particles_{p}"] for p in PARTICLES}
              for e in ELEMENTS}
    save_json(os.path.join(args.out, "weights.json"),
              {"cases": {k: {"file": c, "set": s} for k, (c, s) in cases.items()},
               "samples_s": samples, "median_s": medians, "ratios": ratios})
    lines = ["| variant | us per point-step (median) | samples |", "|---|---|---|"]
    lines += [f"| {k} | {1e6 * medians[k]:.3f} | "
              f"{', '.join(f'{1e6 * x:.3f}' for x in samples[k])} |" for k in cases]
    lines += ["", "| element / particle-step | " + " | ".join(PARTICLES) + " |",
              "|---|" + "---|" * len(PARTICLES)]
    lines += [f"| {e} | " + " | ".join(f"{ratios[e][p]:.2f}" for p in PARTICLES) + " |"
              for e in ELEMENTS]
    write_lines(os.path.join(args.out, "weights.md"), lines, echo=True)


if __name__ == "__main__":
    main()
