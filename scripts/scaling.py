"""Scaling across ranks (issue 25): run a case on 1, 2, 4 and 8 ranks (oversubscribed
here: only the answers and the counts mean anything, not the times), check that the
answers agree, and project strong-scaling efficiency at 16, 64 and 256 ranks with a
model built from what was measured.

    python scripts/scaling.py [--case taylor|perforation] [--ranks 1 2 4 8]
        [--latency-us 1.5] [--bandwidth-gbs 12] [--out results/scaling]

The model, per step of the target case on P ranks:

    T(P) = t_0 + t_p N_p imbalance(P) / P                  compute
         + m_nb (alpha + b_nb / beta)                       neighbour messages
         + m_coll alpha ceil(log2 P)                        collectives (latency-bound)
         + m_a2a alpha + b_a2a / beta                       migration (all-to-all)

* ``t_p``, ``t_0``: seconds per particle-step and per step on one rank, fitted to two
  1-rank runs here (the case as measured and with fewer particles): the grid's work per
  particle is in ``t_p``; ``t_0`` is what every step costs whatever its size (Python's
  orchestration of the kernels, the reductions), which no rank count divides.
* ``m_nb``, ``b_nb``: the neighbour messages and bytes per step of the busiest rank
  (summary.json ``communication``, an interior rank at 4 or more ranks), its bytes
  scaled by the target's plane area in nodes, ``(h / h_target)^2``.
* ``m_coll``: collectives per step (the time step, faults, migration checks).
* ``imbalance(P)``: the busiest slab's particles over the mean, for P slabs cut by
  pmpm's own rule (``pmpm.comm.slabs.balanced_bounds``, at least ``1 + 2 halo`` cells
  wide) on the target's particle histogram along the slab axis (the measured frame's
  particles binned at the target's cell).
* ``alpha``, ``beta``: the interconnect's latency and bandwidth, stated on the command
  line (defaults: 1.5 us, 12 GB/s, an InfiniBand HDR-class network).

Efficiency is T(1) / (P T(P)). The largest P the slabs admit is the material's extent
along the slab axis in cells over the narrowest slab. The model is checked against the
measured 2-rank efficiency on this machine (shared memory: latency and bandwidth given
by ``--local-latency-us``/``--local-bandwidth-gbs``).
Writes ``OUT/scaling.md`` (the tables) and ``OUT/scaling.json``.
"""
import argparse
import json
import math
import os
import sys

import h5py
import numpy as np

from _common import ROOT, provenance, run_case, write_lines

sys.path.insert(0, ROOT)
from pmpm.comm.slabs import balanced_bounds  # noqa: E402
from pmpm.kernels.shape import HALO, SHAPE_CODES  # noqa: E402

CASES = {
    # name: (case file, sets of the measured runs, measured cell, target cell, label,
    # the sets of a second 1-rank run with fewer particles, which splits the step's cost
    # into a part per particle and a fixed part per step)
    "taylor": ("runs/taylor_bar.yaml",
               ["params.cell=0.76", "time.end=0.004", "output.checkpoints=false",
                "output.frames=1"], 0.76, 0.19, "Taylor bar, 0.19 mm (1.34 M particles)",
               ["params.cell=1.14"]),
    "perforation": ("runs/ogive_plate.yaml",
                    ["time.end=0.004", "output.checkpoints=false", "output.frames=1"],
                    2.0, 1.0, "ogive perforation, 1 mm cells (8 x the paper's count)",
                    ["params.ppc_plate=1", "params.ppc_rod=2"]),
}
PROJECTED = (16, 64, 256)


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", choices=sorted(CASES), default="taylor")
    p.add_argument("--ranks", type=int, nargs="+", default=[1, 2, 4, 8])
    p.add_argument("--latency-us", type=float, default=1.5)
    p.add_argument("--bandwidth-gbs", type=float, default=12.0)
    p.add_argument("--local-latency-us", type=float, default=0.5)
    p.add_argument("--local-bandwidth-gbs", type=float, default=5.0)
    p.add_argument("--tolerance", type=float, default=1e-10)
    p.add_argument("--shape", choices=("linear", "gimp", "bspline"), default=None,
                   help="grid.shape_functions of the runs (default: the case file's)")
    p.add_argument("--out", default=os.path.join(ROOT, "results", "scaling"))
    return p.parse_args(argv)


def final_frame(out):
    with h5py.File(os.path.join(out, "particles.h5"), "r") as f:
        group = f["frames"][sorted(f["frames"])[-1]]
        data = {k: group[k][()] for k in ("id", "x", "v", "stress")}
    order = np.argsort(data["id"])
    return {k: v[order] for k, v in data.items()}


def first_positions(out, samples=8):
    """The first frame's particles as points spread over each particle's own cube
    (``samples`` per axis, a lattice within the spacing), so that a histogram at a finer
    cell than the measured particle spacing sees material, not the gaps between layers."""
    with h5py.File(os.path.join(out, "particles.h5"), "r") as f:
        group = f["frames"][sorted(f["frames"])[0]]
        x = group["x"][()]
        spacing = np.cbrt(group["mass"][()] / group["density"][()])
    offsets = (np.arange(samples) + 0.5) / samples - 0.5
    return x, spacing, offsets


def spread(points, axis):
    """The positions along ``axis`` of the spread samples (see :func:`first_positions`)."""
    x, spacing, offsets = points
    return (x[:, axis][:, None] + spacing[:, None] * offsets[None, :]).ravel()


def largest_difference(a, b):
    """The largest difference of positions, velocities and stresses, relative to each
    field's largest magnitude."""
    if not np.array_equal(a["id"], b["id"]):
        return math.inf
    worst = 0.0
    for key in ("x", "v", "stress"):
        scale = max(np.abs(a[key]).max(), 1e-300)
        worst = max(worst, float(np.abs(a[key] - b[key]).max() / scale))
    return worst


def busiest(summary, kind, what):
    return summary["communication"][kind][what]["largest"]


def imbalance(positions, axis, cell, ranks, min_width):
    """(busiest slab / mean) for ``ranks`` slabs on the particles' histogram at ``cell``,
    or None when the slabs cannot be that many."""
    along = spread(positions, axis)
    cells = np.floor((along - along.min()) / cell).astype(np.int64)
    counts = np.bincount(cells - cells.min())
    try:
        bounds = balanced_bounds(counts, ranks, min_width)
    except ValueError:
        return None
    cumulative = np.concatenate([[0], np.cumsum(counts)])
    per = cumulative[bounds[1:]] - cumulative[bounds[:-1]]
    return float(per.max() / per.mean())


def best_axis(positions, cell, ranks, min_width):
    """(axis, imbalance) of the axis whose slabs balance best (pmpm's ``axis: auto``), or
    (None, None) when no axis admits ``ranks`` slabs."""
    found = [(imb, axis) for axis in range(3)
             if (imb := imbalance(positions, axis, cell, ranks, min_width)) is not None]
    if not found:
        return None, None
    imb, axis = min(found)
    return axis, imb


def plane_nodes(positions, axis, cell, halo):
    """Nodes of a slab plane normal to ``axis``: the material's extent across it in
    nodes, widened by the halo on both sides."""
    span = np.ptp(positions[0], axis=0) / cell + 2 + 2 * halo
    return float(np.prod([span[a] for a in range(3) if a != axis]))


def model(t_p, n_p, ranks, imb, comm, alpha, beta, t_0=0.0):
    """Seconds per step on ``ranks`` ranks (see the module docstring)."""
    compute = t_0 + t_p * n_p * imb / ranks
    if ranks == 1:
        return compute
    nb = comm["m_nb"] * (alpha + comm["b_nb"] / comm["m_nb"] / beta) if comm["m_nb"] else 0.0
    coll = comm["m_coll"] * alpha * math.ceil(math.log2(ranks))
    a2a = comm["m_a2a"] * alpha + comm["b_a2a"] / beta
    return compute + nb + coll + a2a


def main(argv=None):
    args = parse_args(argv)
    case, sets, h_meas, h_target, label, fewer = CASES[args.case]
    if args.shape:
        sets = sets + [f"grid.shape_functions={args.shape}"]
    runs = {}
    for ranks in args.ranks:
        out = os.path.join(args.out, f"{args.case}_{args.shape or 'file'}_r{ranks}")
        runs[ranks] = (out, run_case(case, out, ranks, sets))
    reference = final_frame(runs[1][0])
    agree = {r: largest_difference(reference, final_frame(out))
             for r, (out, _) in runs.items()}
    one = runs[1][1]
    n_meas = one["n_particles"]["initial"]
    coarse = run_case(case, os.path.join(args.out, f"{args.case}_{args.shape or 'file'}_coarse"),
                      1, sets + fewer)
    t_0, t_p = fit_step_cost(one, coarse)
    scale3 = (h_meas / h_target) ** 3
    scale2 = (h_meas / h_target) ** 2
    widest = max(r for r in runs if r > 1)
    s_w = runs[widest][1]
    shape_name = args.shape or shape_functions(runs[1][0])
    shape = SHAPE_CODES[shape_name]
    halo = HALO[shape]
    min_width = 1 + 2 * halo
    positions = first_positions(runs[1][0])
    measured_axis = "xyz".index(s_w["slabs"]["axis"])
    # bytes per node of a shared plane and message, from the widest measured run
    per_node = busiest(s_w, "neighbour", "bytes_per_step") / max(
        busiest(s_w, "neighbour", "messages_per_step"), 1) / plane_nodes(
        positions, measured_axis, h_meas, halo)
    comm = {"m_nb": busiest(s_w, "neighbour", "messages_per_step"),
            "m_coll": busiest(s_w, "collective", "messages_per_step"),
            "m_a2a": busiest(s_w, "alltoall", "messages_per_step"),
            "b_a2a": busiest(s_w, "alltoall", "bytes_per_step") * scale2}
    n_target = n_meas * scale3
    alpha, beta = args.latency_us * 1e-6, args.bandwidth_gbs * 1e9
    rows, projection = [], {}
    t1 = t_0 + t_p * n_target
    for ranks in list(PROJECTED):
        axis, imb = best_axis(positions, h_target, ranks, min_width)
        if imb is not None:
            comm["b_nb"] = comm["m_nb"] * per_node * plane_nodes(positions, axis, h_target,
                                                                 halo)
        if imb is None:
            projection[ranks] = None
            rows.append(f"| {ranks} | - | - | - | - | slabs of {min_width} cells cannot "
                        f"be {ranks} |")
            continue
        tp = model(t_p, n_target, ranks, imb, comm, alpha, beta, t_0)
        eff = t1 / (ranks * tp)
        projection[ranks] = {"axis": "xyz"[axis], "imbalance": imb, "step_s": tp,
                             "efficiency": eff, "bytes_per_message": comm["b_nb"] / comm["m_nb"]}
        compute = t_0 + t_p * n_target * imb / ranks
        rows.append(f"| {ranks} | {'xyz'[axis]} | {imb:.3f} | {1e3 * compute:.2f} | "
                    f"{1e3 * (tp - compute):.3f} | {100 * eff:.1f} % |")
    extents = np.ceil(np.ptp(positions[0], axis=0) / h_target).astype(int)
    largest = int(extents.max()) // min_width
    # the check: the 2-rank efficiency this model gives with this machine's shared memory
    check = None
    if 2 in runs:
        s2 = runs[2][1]
        c2 = {"m_nb": busiest(s2, "neighbour", "messages_per_step"),
              "b_nb": busiest(s2, "neighbour", "bytes_per_step"),
              "m_coll": busiest(s2, "collective", "messages_per_step"),
              "m_a2a": busiest(s2, "alltoall", "messages_per_step"),
              "b_a2a": busiest(s2, "alltoall", "bytes_per_step")}
        imb2 = imbalance(positions, measured_axis, h_meas, 2, min_width) or 1.0
        a_l, b_l = args.local_latency_us * 1e-6, args.local_bandwidth_gbs * 1e9
        modelled = model(t_p, n_meas, 1, 1.0, c2, a_l, b_l, t_0) / (
            2 * model(t_p, n_meas, 2, imb2, c2, a_l, b_l, t_0))
        measured = s2["particle_steps_per_s"] / (2 * one["particle_steps_per_s"])
        check = {"modelled": modelled, "measured": measured}
    lines = [f"# Scaling: {label}, {shape_name}", "",
             f"Measured at {h_meas} mm on {', '.join(map(str, runs))} ranks "
             f"({n_meas:,} particles, `{case}` with {' '.join(sets)}); projected to "
             f"{h_target} mm ({n_target:,.0f} particles).", "",
             "| ranks | largest relative difference from 1 rank (x, v, stress) | "
             "neighbour messages / bytes per step (busiest rank) | collectives per step |",
             "|---|---|---|---|"]
    for ranks, (_, s) in runs.items():
        lines.append(f"| {ranks} | {agree[ranks]:.2e} | "
                     f"{busiest(s, 'neighbour', 'messages_per_step'):.1f} / "
                     f"{busiest(s, 'neighbour', 'bytes_per_step'):,.0f} | "
                     f"{busiest(s, 'collective', 'messages_per_step'):.1f} |")
    lines += ["", f"Model inputs: t_p = {1e9 * t_p:.0f} ns per particle-step and t_0 = "
              f"{1e3 * t_0:.2f} ms per step (1 rank, this machine); per step {comm['m_nb']:.0f} neighbour messages of "
              f"{per_node:.0f} bytes per node of a shared plane, "
              f"{comm['m_coll']:.1f} collectives; latency {args.latency_us} us, "
              f"bandwidth {args.bandwidth_gbs} GB/s; slabs at least {min_width} cells.", "",
              "| ranks | slab axis | imbalance | compute ms/step | communication ms/step | "
              "projected efficiency |", "|---|---|---|---|---|---|", *rows, "",
              f"The slabs admit at most {largest} ranks ({int(extents.max())} cells of "
              f"material along the longest axis, at least {min_width} per slab)."]
    if check:
        lines += ["", f"Check at 2 ranks on this machine: modelled efficiency "
                      f"{100 * check['modelled']:.1f} %, measured {100 * check['measured']:.1f} % "
                      f"(oversubscribed runs: the measured figure is only meaningful on an "
                      f"idle machine with a core per rank)."]
    ok = all(d <= args.tolerance for d in agree.values())
    lines += ["", f"Answers agree to {args.tolerance:g}: {'yes' if ok else 'NO'}"]
    name = f"scaling_{args.case}_{args.shape or 'file'}"
    write_lines(os.path.join(args.out, f"{name}.md"), lines, echo=True)
    with open(os.path.join(args.out, f"{name}.json"), "w",
              encoding="utf-8") as f:
        json.dump({**provenance("scaling.py"), "label": label, "case": case, "sets": sets,
                   "shape": shape_name, "agree": agree, "comm": comm,
                   "t_p": t_p, "t_0": t_0, "projection": projection,
                   "largest_ranks": largest, "check": check}, f, indent=2)
    return 0 if ok else 1


def step_seconds(summary):
    """(particles, seconds per step) of a run, over its steps after the first."""
    n = summary["n_particles"]["initial"]
    return n, n / summary["particle_steps_per_s"]


def fit_step_cost(fine, coarse):
    """(t_0, t_p): the fixed and per-particle cost of a step, from two runs' steps."""
    (n1, s1), (n2, s2) = step_seconds(fine), step_seconds(coarse)
    t_p = (s1 - s2) / (n1 - n2)
    return max(s1 - t_p * n1, 0.0), t_p


def shape_functions(out):
    """The run's grid.shape_functions, from the case text kept in particles.h5."""
    import yaml
    with h5py.File(os.path.join(out, "particles.h5"), "r") as f:
        text = f["case"][()]
    text = text.decode() if isinstance(text, bytes) else str(text)
    grid = (yaml.safe_load(text) or {}).get("grid", {})
    return grid.get("shape_functions", "gimp")


if __name__ == "__main__":
    sys.exit(main())
