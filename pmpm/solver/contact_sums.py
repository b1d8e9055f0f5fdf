"""Sums over the ranks that the contacts with FEM faces share (particle-to-surface,
pmpm.solver.surface_contact, and node-to-surface, pmpm.solver.node_contact).

A contact pair is computed on one rank, but the FE nodes it pushes may be held by
several (their elements live on different ranks). What a pair gives a node is a row
keyed by (node id, pair key), the pair key being the particle id or the slave node id.
Every sum over such rows is taken in (node id, pair key) order, so the same rows give
the same sums bit for bit however they were spread over ranks and however they arrive:
1 rank agrees with N to round-off, and every copy of a shared node takes the same total.
The messages are packed sparse exchanges (pmpm.comm.sparse.exchange_arrays): one
message to each rank that gets rows, none to the others; the answers of the home ranks
go back to the ranks that asked, which both sides know from the questions
(pmpm.comm.sparse.exchange_known: no barrier, and no message where nobody asked).
"""
import numpy as np

from ..comm.sparse import exchange_arrays, exchange_known, sent_to, senders


def sums_in_order(gid, pid, rows):
    """(sorted unique node ids, the sums of ``rows`` per node), each sum taken in
    particle id order (so the same rows give the same sums however they arrive)."""
    order = np.lexsort((pid, gid))
    ids, at = np.unique(gid[order], return_inverse=True)
    total = np.zeros((len(ids),) + rows.shape[1:])
    np.add.at(total, at.ravel(), rows[order])
    return ids, total


def sums_at_home(world, gid, pid, rows, home):
    """(node ids, sums of ``rows``) of the nodes in ``gid``, over all ranks (collective):
    each rank sends its rows to the node's ``home`` rank (its lowest holder), which sums
    them in (node id, pair key ``pid``) order and answers with the totals."""
    questions = [(gid[home == r], pid[home == r], rows[home == r])
                 for r in range(world.size)]
    asks = exchange_arrays(world, questions)
    ids, total = sums_in_order(np.concatenate([a[0] for a in asks]),
                               np.concatenate([a[1] for a in asks]),
                               np.concatenate([a[2] for a in asks]))
    answers = []
    for ask in asks:
        mine = np.unique(ask[0])
        answers.append((mine, total[np.searchsorted(ids, mine)]))
    # the answers go back to the ranks that asked, known to both sides from the asks
    back = exchange_known(world, answers, senders(asks, world.rank),
                        sent_to(questions, world.rank))
    ids = np.concatenate([a for a, _ in back])
    total = np.concatenate([b for _, b in back])
    order = np.argsort(ids)
    return ids[order], total[order]


def sums_at_holders(world, gid, pid, rows, holders, node_id):
    """(nodes, sums): the local nodes (``node_id``: this rank's node ids, ascending)
    that rows of any rank are addressed to, ascending, and per node the sum of those
    rows. Each row goes to every rank of its node's ``holders`` (ranks, padded with -1)
    and is summed there in (node id, pair key ``pid``) order (collective). Only the nodes
    that take rows: a pass over all nodes with (n, 3) views cost 2.6 of the node
    contact's 3.2 s in the 2 mm perforation."""
    parts = [(gid, pid, rows)] if world.size == 1 else exchange_arrays(
        world, [(gid[w], pid[w], rows[w]) for w in
                ((holders == r).any(axis=1) for r in range(world.size))])
    gid = np.concatenate([part[0] for part in parts])
    pid = np.concatenate([part[1] for part in parts])
    rows = np.concatenate([part[2] for part in parts])
    order = np.lexsort((pid, gid))
    nodes, at = np.unique(np.searchsorted(node_id, gid[order]), return_inverse=True)
    sums = np.zeros((len(nodes),) + rows.shape[1:])
    np.add.at(sums, at.ravel(), rows[order])
    return nodes, sums


def node_holders(rank, partners, n_nodes):
    """(n_nodes, k) the ranks holding each local node, ascending, padded with -1."""
    nodes = np.concatenate([np.arange(n_nodes, dtype=np.int64)]
                           + [np.asarray(idx, np.int64) for _, idx in partners])
    ranks = np.concatenate([np.full(n_nodes, rank, np.int64)]
                           + [np.full(len(idx), other, np.int64) for other, idx in partners])
    order = np.lexsort((ranks, nodes))
    nodes, ranks = nodes[order], ranks[order]
    starts = np.searchsorted(nodes, np.arange(n_nodes, dtype=np.int64))
    column = np.arange(len(nodes), dtype=np.int64) - starts[nodes]
    width = int(column.max()) + 1 if len(column) else 1
    out = np.full((n_nodes, width), -1, np.int64)
    out[nodes, column] = ranks
    return out


def pad_holders(holders, width):
    """Widen (ns, 4, k) holder lists to ``width`` with -1."""
    out = np.full(holders.shape[:-1] + (width,), -1, np.int64)
    out[..., :holders.shape[-1]] = holders
    return out
