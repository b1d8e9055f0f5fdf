"""Sums over the finite-element nodes that several ranks hold (seed 004 notes Sec. 4):
each rank sends its partial values of the nodes it shares with a neighbour in one packed
message, and every sharer adds the partials in rank order, so that the copies of a
shared node stay bitwise equal and 1 rank agrees with N to round-off."""
import numpy as np

from .sparse import exchange_known
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


def sum_shared_rows_in_element_order(world, values, partners, hexes, element_id,
                                     contributions):
    """Like :func:`sum_shared_rows`, to the bit of one rank: a shared node's total is
    the sum, from 0, of the contributions of every sharer's elements to it in global
    element id order, which is the order one rank adds them in (its elements are held
    in id order, ``element_forces`` adds them in array order).

    Parameters
    ----------
    values : (n, k) this rank's sums on its nodes (those on shared nodes are replaced)
    partners : as for :func:`sum_shared_rows`
    hexes : (n_elements, 8) local node of each element corner
    element_id : (n_elements,) global ids
    contributions : (n_elements, 8, k) each element's part of ``values`` at each corner
    """
    if not partners:
        return values
    shared = np.zeros(len(values), bool)
    for _, idx in partners:
        shared[idx] = True
    e, k = np.nonzero(shared[hexes])
    nodes, ids, parts = hexes[e, k], element_id[e], contributions[e, k]
    received = swap_arrays(world, {rank: _on_partner_nodes(idx, nodes, ids, parts,
                                                           len(values))
                                   for rank, idx in partners})
    for rank, idx in partners:
        position, their_ids, their_parts = received[rank]
        nodes = np.concatenate([nodes, idx[position]])
        ids, parts = np.concatenate([ids, their_ids]), np.concatenate([parts, their_parts])
    order = np.lexsort((ids, nodes))
    total = values.copy()
    total[shared] = 0.0
    np.add.at(total, nodes[order], parts[order])        # in order, one row at a time
    return total


def _on_partner_nodes(idx, nodes, ids, parts, n_nodes):
    """(position in the partner's shared list, element id, contribution) of the rows on
    the nodes ``idx`` shared with one partner."""
    position = np.full(n_nodes, -1, np.int64)
    position[idx] = np.arange(len(idx))
    on = position[nodes] >= 0
    return position[nodes[on]], ids[on], parts[on]


def swap_arrays(world, packages):
    """Send ``packages[r]`` (a tuple of arrays, packed into one buffer) to each rank r
    of ``packages`` and return what each of them sent here, {rank: tuple of arrays}.
    Each partner gets its own share only, without a pickle or a barrier
    (pmpm.comm.sparse.exchange_known: the partners are known to both sides). Every rank
    of ``packages`` must call it with this rank among its own (a symmetric relation),
    or it waits for ever."""
    if not packages:
        return {}
    ranks = list(packages)
    template = packages[ranks[0]]
    mine = [packages.get(r, template) for r in range(world.size)]
    got = exchange_known(world, mine, ranks, ranks)
    return {r: got[r] for r in ranks}


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

