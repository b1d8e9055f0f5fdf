"""Sums over the finite-element nodes that several ranks hold (seed 004 notes Sec. 4):
each rank sends its partial values of the nodes it shares with a neighbour in one packed
message, and every sharer adds the partials in rank order, so that the copies of a
shared node stay bitwise equal and 1 rank agrees with N to round-off."""
import numpy as np

from ..kernels.exact_sum import add_rows_in_order
from .sparse import exchange_known
from .world import payload_bytes

TAG = 79
ORDER_TAG = 82


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


class ElementOrderSums:
    """Like :func:`sum_shared_rows`, to the bit of one rank: a shared node's total is
    the sum, from 0, of the contributions of every sharer's elements to it in global
    element id order, which is the order one rank adds them in (its elements are held
    in id order, ``element_forces`` adds them in array order).

    What depends on the mesh alone (which elements have a corner on a shared node:
    ``row_of``, their rows of the contributions; where each corner lands on the
    partners'; the order of all of them by node and element id) is found once, with one
    exchange of ids (collective over the partners); each sum then sends only the
    contributions, as raw rows in that order. Build it again, on every rank at once,
    whenever the elements or the partners change. (Made and used at every call, this
    took 1.2 s of a 25 s run of the 2 mm perforation on 2 ranks: a node mask, a lexsort
    and packed messages each step.)"""

    def __init__(self, world, partners, hexes, element_id, n_nodes):
        self.world, self.partners = world, partners
        shared = np.zeros(n_nodes, bool)
        for _, idx in partners:
            shared[idx] = True
        self.shared = np.flatnonzero(shared)
        e, k = np.nonzero(shared[hexes])
        # a row of contributions for each element on a shared node only (at the seed's
        # 1 mm, rows for every element were 30 MB a rank written and zeroed each step)
        on_shared = np.unique(e)
        self.row_of = np.full(len(hexes), -1, np.int64)
        self.row_of[on_shared] = np.arange(len(on_shared))
        self.n_rows = len(on_shared)
        self.corners = self.row_of[e] * hexes.shape[1] + k   # in contributions (rows*8, k)
        nodes, ids = hexes[e, k], element_id[e]
        self.sends, packages = [], {}
        for rank, idx in partners:
            position, on = _on_partner_nodes(idx, nodes, n_nodes)
            self.sends.append(on)
            packages[rank] = (position, ids[on])
        received = swap_arrays(world, packages)
        all_nodes, all_ids, self.counts = [nodes], [ids], []
        for rank, idx in partners:
            position, their_ids = received[rank]
            all_nodes.append(idx[position])
            all_ids.append(their_ids)
            self.counts.append(len(position))
        all_nodes, all_ids = np.concatenate(all_nodes), np.concatenate(all_ids)
        self.order = np.lexsort((all_ids, all_nodes))
        self.nodes = all_nodes[self.order]

    def total(self, values, contributions):
        """``values`` (n, k), this rank's sums, with each shared node's replaced, in
        place, by the sum of every sharer's ``contributions`` (n_rows, 8, k: the
        elements' of ``row_of``) in (node, element id) order; returns ``values``."""
        width = values.shape[1]
        mine = contributions.reshape(-1, width)[self.corners]
        incoming = [np.empty((n, width)) for n in self.counts]
        outgoing = [np.ascontiguousarray(mine[on]) for on in self.sends]
        requests = []
        for (rank, _), out, into in zip(self.partners, outgoing, incoming):
            requests.append(self.world.raw.Irecv(into, source=rank, tag=ORDER_TAG))
            requests.append(self.world.raw.Isend(out, dest=rank, tag=ORDER_TAG))
            self.world.traffic.note("neighbour", out.nbytes)
        for request in requests:
            request.Wait()
        values[self.shared] = 0.0
        add_rows_in_order(values, self.nodes, np.concatenate([mine] + incoming), self.order)
        return values


def _on_partner_nodes(idx, nodes, n_nodes):
    """(position in the partner's shared list, which rows) of the rows ``nodes`` on
    the nodes ``idx`` shared with one partner."""
    position = np.full(n_nodes, -1, np.int64)
    position[idx] = np.arange(len(idx))
    on = position[nodes] >= 0
    return position[nodes[on]], on


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

