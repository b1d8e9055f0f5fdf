"""Where 1 rank and N ranks part: run a case on COMM_WORLD and, on rank 0, on COMM_SELF
side by side, step by step, and print per step the largest difference of the coarse
grid's nodal arrays (after their shared-plane sums; ``_first``: the step's first
scatter) and of the particles (by id), and the planes along the slab axis where the
nodal arrays differ (global node index).

    mpirun -n 2 python scripts/rank_diff.py CASE STEPS [--set key=value ...]
"""
import argparse
import os
import sys

import numpy as np
from mpi4py import MPI

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from runhelp import set_up  # noqa: E402
from pmpm.comm import World  # noqa: E402
from pmpm.solver import step as step_module  # noqa: E402

RECORDED = {}


def record(name, array_name):
    """Wrap Stepper.<name> to keep the coarse level's ``array_name`` after it runs."""
    original = getattr(step_module.Stepper, name)

    def wrapped(self, *args):
        out = original(self, *args)
        s = self.grids.states[0]
        kept = RECORDED.setdefault(id(self), {})
        if array_name + "_first" not in kept:
            kept[array_name + "_first"] = (s.block, getattr(s, array_name).copy())
        kept[array_name] = (s.block, getattr(s, array_name).copy())
        return out
    setattr(step_module.Stepper, name, wrapped)


record("map_to_grid", "nodal")
record("complete_forces", "force")


def on_global_grid(sim, comm, name):
    """The coarse array ``name`` on global node indices (+2 offset), gathered to rank 0
    (NaN where no rank holds the node). A node two ranks hold takes the lower rank's
    copy (the shared plane's owner); where the copies differ (a halo plane a rank holds
    but does not complete) a line says on how many nodes, so that a copy's difference
    is not read as the grid's."""
    block, values = RECORDED[id(sim.stepper)][name]
    n = sim.grid.n_cells + 5
    full = np.full((*n, values.shape[1]), np.nan)
    idx = np.indices(block.shape).reshape(3, -1).T + block.lo + 2
    flat = np.indices(block.shape).reshape(3, -1).T @ block.strides
    full[idx[:, 0], idx[:, 1], idx[:, 2]] = values[flat]
    parts = comm.gather(full, root=0)
    if comm.rank:
        return None
    out = np.full_like(full, np.nan)
    for rank, part in enumerate(parts):
        have = ~np.isnan(part)
        taken = have & ~np.isnan(out)
        differ = (taken & (part != out)).any(axis=-1).sum()
        if differ:
            print(f"{name}: rank {rank}'s copy differs from a lower rank's on {differ} nodes"
                  " (the lower rank's is kept)")
        new = have & np.isnan(out)
        out[new] = part[new]
    return out


def particles(sim, comm):
    p = sim.particles
    return gathered_by_id(comm, p.id.copy(), p.x.copy(), p.v.copy())


def fe_nodes(sim, comm):
    """The owned FE nodes' (id, x, v) gathered to rank 0 by id, or None without any."""
    fem = sim.elements
    if fem is None:
        return None
    own = fem.owned
    return gathered_by_id(comm, fem.node_id[own], fem.x[own], fem.v[own])


def gathered_by_id(comm, ids, x, v):
    """Every rank's (ids, x, v) on rank 0, rows sorted by id; None on the others."""
    parts = comm.gather((ids, x, v), root=0)
    if comm.rank:
        return None
    every = np.concatenate([a[0] for a in parts])
    order = np.argsort(every)
    return every[order], np.concatenate([a[1] for a in parts])[order], \
        np.concatenate([a[2] for a in parts])[order]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("steps", type=int)
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--dt", type=float, default=None)
    ap.add_argument("--every", type=int, default=1, help="print every so many steps")
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    many = set_up(args.case, args.set, World(comm))
    one = set_up(args.case, args.set) if comm.rank == 0 else None
    dt = args.dt or 0.25 * many.grid.h / max(many.fastest_speed(), 1e-30)
    if comm.rank == 0:
        print(many.slabs.describe(), flush=True)
    for step in range(1, args.steps + 1):
        many.advance(dt)
        if one is not None:
            one.advance(dt)
        row = []
        names = ("nodal", "force") if step > 1 else ("nodal_first", "force_first", "nodal",
                                                     "force")
        for name in names:
            a = on_global_grid(many, comm, name)
            if comm.rank == 0:
                b = on_global_grid(one, MPI.COMM_SELF, name)
                both = ~np.isnan(a) & ~np.isnan(b)
                d = np.abs(a - b)[both]
                nz = np.argwhere((np.abs(a - b) > 0) & both)
                where = sorted(set(nz[:, many.slabs.axis] - 2)) if len(nz) else []
                row.append(f"{name}: max|d| {d.max():.2e} nodes {len(set(map(tuple, nz[:, :3])))}"
                           f" slab-axis planes {where[:6]}")
        pm = particles(many, comm)
        if comm.rank == 0:
            po = particles(one, MPI.COMM_SELF)
            assert np.array_equal(pm[0], po[0])
            row.append(f"x {np.abs(pm[1] - po[1]).max():.2e} v {np.abs(pm[2] - po[2]).max():.2e}")
        fm = fe_nodes(many, comm)
        if comm.rank == 0 and fm is not None:
            fo = fe_nodes(one, MPI.COMM_SELF)
            assert np.array_equal(fm[0], fo[0])
            row.append(f"FE x {np.abs(fm[1] - fo[1]).max():.2e} v {np.abs(fm[2] - fo[2]).max():.2e}")
        if comm.rank == 0 and (step % args.every == 0 or step == 1):
            print(f"step {step}: " + "; ".join(row), flush=True)


if __name__ == "__main__":
    main()
