"""Sums over the finite-element nodes that several ranks hold (seed 004 notes Sec. 4):
each rank sends its partial values of the nodes it shares with a neighbour in one packed
message, and every sharer adds the partials in rank order, so that the copies of a
shared node stay bitwise equal and 1 rank agrees with N to round-off."""
import numpy as np

from .world import payload_bytes

TAG = 79


def sum_shared_rows(world, values, partners):
    """``values`` (n, k): this rank's partial sums on its nodes. ``partners``: list of
    (rank, local node indices) of the nodes shared with each other rank, in the same
    (global id) order on both sides. Returns the totals: on a shared node the sum of every
    sharer's partial, added in rank order (the same on every sharer)."""
    if not partners:
        return values
    outgoing = [np.ascontiguousarray(values[idx]) for _, idx in partners]
    incoming = [np.empty_like(out) for out in outgoing]
    requests = []
    for (rank, _), out, into in zip(partners, outgoing, incoming):
        requests.append(world.raw.Irecv(into, source=rank, tag=TAG))
        requests.append(world.raw.Isend(out, dest=rank, tag=TAG))
        world.traffic.note("neighbour", out.nbytes)
    for request in requests:
        request.Wait()
    total = np.zeros_like(values)
    parts = sorted([(rank, idx, into) for (rank, idx), into in zip(partners, incoming)]
                   + [(world.rank, None, values)], key=lambda part: part[0])
    for rank, idx, part in parts:
        if idx is None:
            total += part
        else:
            total[idx] += part
    return total


def swap_with(world, ranks, payload, tag=80):
    """Send ``payload`` (a picklable object) to every rank of ``ranks`` and return what
    each of them sent here, {rank: object}. Every rank of ``ranks`` must call it with
    this rank among its own ``ranks`` (a symmetric relation), or it waits for ever."""
    size = payload_bytes(payload) if ranks else 0
    requests = [world.raw.isend(payload, dest=r, tag=tag) for r in ranks]
    world.traffic.note("neighbour", size * len(ranks), len(ranks))
    received = {r: world.raw.recv(source=r, tag=tag) for r in ranks}
    for request in requests:
        request.wait()
    return received

