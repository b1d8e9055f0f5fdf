"""Which elements and nodes of the FEM meshes a rank holds (seed 004 notes Sec. 4):
elements are owned by the slab that holds their centroid; a rank holds the nodes of its
elements; a node used by elements of several ranks is shared, and counted (energies,
momentum, output) by the lowest of them. Plain numpy, the same on every rank."""
from dataclasses import dataclass

import numpy as np

from ..comm.shared_nodes import swap_with


@dataclass
class Partition:
    """One rank's part of a mesh of ``hexes`` (m, 8) global node ids.

    elements : (m_local,) global indices of the elements it owns, ascending
    nodes : (n_local,) global ids of the nodes of those elements, ascending
    hexes : (m_local, 8) their connectivity in local node indices
    partners : list of (rank, local indices of the nodes shared with that rank), by rank
    owned : (n_local,) bool, the nodes this rank counts (the lowest rank using them)
    """
    elements: np.ndarray
    nodes: np.ndarray
    hexes: np.ndarray
    partners: list
    owned: np.ndarray


def partition_mesh(hexes, n_nodes, element_owner, rank, size):
    """The Partition of ``rank`` given each element's owner rank: from the distinct
    (node, user rank) pairs of the connectivity, O(m log m) time and O(n + m) memory on
    each rank (no rank-by-node table)."""
    pairs = np.unique(hexes.ravel() * size + np.repeat(element_owner, hexes.shape[1]))
    node, user = np.divmod(pairs, size)            # by node, then by rank
    elements = np.flatnonzero(element_owner == rank)
    nodes = node[user == rank]
    local = np.full(n_nodes, -1, np.int64)
    local[nodes] = np.arange(len(nodes))
    mine = local[node] >= 0                        # the pairs of this rank's nodes
    partners = [(int(r), local[node[mine & (user == r)]])
                for r in np.unique(user[mine]) if r != rank]
    first = np.flatnonzero(np.r_[True, node[1:] != node[:-1]])
    lowest = np.full(n_nodes, -1, np.int64)
    lowest[node[first]] = user[first]
    return Partition(elements, nodes, local[hexes[elements]], partners,
                     lowest[nodes] == rank)


def element_owners(centroids, grid, slabs):
    """Owner rank of each element: the slab holding its centroid."""
    if len(centroids) == 0:
        return np.zeros(0, np.int64)
    return slabs.owner_of_cells(grid.cells_of(centroids)[:, slabs.axis]).astype(np.int64)


def shared_with(world, node_id, x, pad):
    """(partners, owned) of a rank holding the nodes ``node_id`` (ascending global ids)
    at positions ``x`` (collective: one allgather of bounding boxes, then the node ids
    go only to the ranks whose box, grown by ``pad``, meets this one's: the copies of a
    shared node lie at the same place, so no sharer is missed)."""
    boxes = world.allgather(bounding_box(x))
    near = overlapping(boxes, world.rank, pad)
    return sharers(node_id, world.rank, swap_with(world, near, node_id))


def bounding_box(x):
    """(lo, hi) of the points ``x`` (n, 3); an empty box (lo > hi) when there are none."""
    if not len(x):
        return np.full(3, np.inf), np.full(3, -np.inf)
    return x.min(axis=0), x.max(axis=0)


def overlapping(boxes, rank, pad):
    """The other ranks whose box (lo, hi), grown by ``pad``, meets ``rank``'s."""
    lo, hi = boxes[rank]
    return [r for r, (a, b) in enumerate(boxes) if r != rank and
            np.all(a - pad <= hi + pad) and np.all(lo - pad <= b + pad)]


def sharers(node_id, rank, others):
    """(partners, owned) from the node ids ``others`` {rank: ascending ids} of the other
    ranks that may share nodes: the local indices of the nodes shared with each, in
    global id order, by rank; and which nodes no lower rank holds."""
    partners, owned = [], np.ones(len(node_id), bool)
    for other in sorted(others):
        _, mine, _ = np.intersect1d(node_id, others[other], assume_unique=True,
                                    return_indices=True)
        if len(mine):
            partners.append((other, mine))
            if other < rank:
                owned[mine] = False
    return partners, owned
