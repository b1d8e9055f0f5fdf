"""Time one exchange call (issues 24, 25): the pickled all-to-all the FEM contacts used
before (``comm.alltoall`` of one object per rank, as ``exchange_objects`` did) against
``pmpm.comm.sparse.exchange_arrays`` (packed buffers, NBX), with packages like
particle-to-surface contact's: a halo of 600 segments, 2000 rows of contact sums, and
nothing to send. Each rank sends to the next rank only. The two run in interleaved
blocks of 200 calls; the median and the least time per call are printed.

    mpirun -n 2 --oversubscribe .venv/bin/python scripts/sparse_exchange_bench.py
"""
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

from pmpm.comm import World, exchange_arrays  # noqa: E402

BLOCKS, CALLS = 7, 200


def halo(n):
    """A segment halo of ``n`` faces, the fields of surface_contact.SEGMENT_FIELDS."""
    return {"gid": np.arange(4 * n, dtype=np.int64).reshape(n, 4), "x": np.ones((n, 4, 3)),
            "x0": np.ones((n, 4, 3)), "v": np.ones((n, 4, 3)), "inv_m": np.ones((n, 4)),
            "body": np.ones(n, np.int64), "key": np.arange(n, dtype=np.int64),
            "holders": np.zeros((n, 4, 2), np.int64)}


def sums(n):
    """Rows of contact_sums: node id, pair key, impulse."""
    return np.arange(n, dtype=np.int64), np.arange(n, dtype=np.int64), np.ones((n, 3))


def per_call(world, exchange, packages):
    world.raw.Barrier()
    start = time.perf_counter()
    for _ in range(CALLS):
        exchange(packages)
    world.raw.Barrier()
    return (time.perf_counter() - start) / CALLS


def main():
    from mpi4py import MPI
    world = World(MPI.COMM_WORLD)
    ways = {"old": world.raw.alltoall,
            "new": lambda packages: exchange_arrays(world, packages)}
    nxt = (world.rank + 1) % world.size
    for label, make, n in (("halo, 600 segments", halo, 600), ("sums, 2000 rows", sums, 2000),
                           ("nothing to send", sums, 0)):
        packages = [make(n) if r == nxt else make(0) for r in range(world.size)]
        took = {"old": [], "new": []}
        for block in range(BLOCKS):
            for name in ("old", "new") if block % 2 == 0 else ("new", "old"):
                took[name].append(per_call(world, ways[name], packages))
        if world.is_root:
            old, new = (1e6 * np.array(took[k]) for k in ("old", "new"))
            print(f"{world.size} ranks, {label}: old {np.median(old):.0f} us, new "
                  f"{np.median(new):.0f} us per call (least {old.min():.0f} / "
                  f"{new.min():.0f})", flush=True)


if __name__ == "__main__":
    main()
