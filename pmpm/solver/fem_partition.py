"""Which elements and nodes of the FEM meshes a rank holds (seed 004 notes Sec. 4):
elements are owned by the slab that holds their centroid; a rank holds the nodes of its
elements; a node used by elements of several ranks is shared, and counted (energies,
momentum, output) by the lowest of them. Plain numpy, the same on every rank."""
from dataclasses import dataclass

import numpy as np


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
    """The Partition of ``rank`` given each element's owner rank."""
    used = np.zeros((size, n_nodes), bool)
    for r in range(size):
        used[r, hexes[element_owner == r].ravel()] = True
    elements = np.flatnonzero(element_owner == rank)
    nodes = np.flatnonzero(used[rank])
    local = np.full(n_nodes, -1, np.int64)
    local[nodes] = np.arange(len(nodes))
    partners = []
    for r in range(size):
        common = np.flatnonzero(used[rank] & used[r]) if r != rank else []
        if len(common):
            partners.append((r, local[common]))
    owned = np.argmax(used[:, nodes], axis=0) == rank if len(nodes) else np.zeros(0, bool)
    return Partition(elements, nodes, local[hexes[elements]], partners, owned)


def element_owners(centroids, grid, slabs):
    """Owner rank of each element: the slab holding its centroid."""
    if len(centroids) == 0:
        return np.zeros(0, np.int64)
    return slabs.owner_of_cells(grid.cells_of(centroids)[:, slabs.axis]).astype(np.int64)


def shared_with(world, node_id):
    """(partners, owned) of a rank holding the nodes ``node_id`` (ascending global ids),
    from every rank's ids (collective): the local indices of the nodes shared with each
    other rank, in global id order, and which nodes no lower rank holds."""
    every = world.allgather(node_id)
    partners, owned = [], np.ones(len(node_id), bool)
    for rank, ids in enumerate(every):
        if rank == world.rank:
            continue
        _, mine, _ = np.intersect1d(node_id, ids, assume_unique=True, return_indices=True)
        if len(mine):
            partners.append((rank, mine))
            if rank < world.rank:
                owned[mine] = False
    return partners, owned
