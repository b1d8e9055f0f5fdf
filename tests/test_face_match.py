"""Faces two elements share (pmpm.kernels.face_match) and the nodes' holder lists
(pmpm.solver.contact_sums.node_holders): the hash and the vectorised lists give what
the sort and the Python lists they replace gave."""
import numpy as np
import pytest

from pmpm.kernels.face_match import matching_face_counts
from pmpm.solver.contact_sums import node_holders


def counts_by_sorting(gids):
    _, inverse, counts = np.unique(np.sort(gids, axis=1), axis=0, return_inverse=True,
                                   return_counts=True)
    return counts[inverse.ravel()]


@pytest.mark.parametrize("n_ids", [6, 40, 10 ** 6])
def test_faces_with_the_same_nodes_are_counted_in_any_order(n_ids):
    """Random faces over few ids (many repeats, rows permuted) and over many (almost
    none): every face's count of faces with its four nodes, as sorting finds it."""
    rng = np.random.default_rng(n_ids)
    gids = rng.integers(0, n_ids, (20000, 4))
    gids[::3] = rng.permuted(gids[1::3][: len(gids[::3])], axis=1)
    assert (matching_face_counts(gids) == counts_by_sorting(gids)).all()


def test_a_hexahedral_mesh_has_its_boundary_faces_free():
    """A 3 x 2 x 2 block of unit hexahedra: the faces counted once are its
    2 (3 * 2 + 3 * 2 + 2 * 2) = 32 boundary faces, the interior ones twice."""
    from pmpm.case.hexmesh import hex_mesh
    from pmpm.fem.hexahedron import FACES
    _, hexes = hex_mesh({"type": "box", "min": [0, 0, 0], "max": [3, 2, 2]}, 1.0)
    counts = matching_face_counts(hexes[:, FACES].reshape(-1, 4))
    assert (counts == 1).sum() == 2 * (3 * 2 + 3 * 2 + 2 * 2)
    assert set(np.unique(counts)) == {1, 2}


def holders_by_lists(rank, partners, n_nodes):
    lists = [[rank] for _ in range(n_nodes)]
    for other, idx in partners:
        for i in idx:
            lists[i].append(other)
    width = max((len(l) for l in lists), default=1)
    out = np.full((n_nodes, width), -1, np.int64)
    for i, l in enumerate(lists):
        out[i, :len(l)] = sorted(l)
    return out


def test_node_holders_list_the_ranks_in_ascending_order():
    rng = np.random.default_rng(3)
    for _ in range(200):
        n, rank = int(rng.integers(0, 40)), int(rng.integers(0, 6))
        others = [r for r in range(6) if r != rank]
        rng.shuffle(others)
        partners = [(r, np.sort(rng.choice(n, int(rng.integers(0, n + 1)), replace=False)))
                    for r in others[:int(rng.integers(0, 4))]]
        got, want = node_holders(rank, partners, n), holders_by_lists(rank, partners, n)
        assert got.shape == want.shape and (got == want).all()


def test_faces_of_a_table_are_counted_for_each_query_face():
    """matches_in: for each query face the number of table faces with its four nodes
    (rows permuted), as sorting the two together finds it."""
    from pmpm.kernels.face_match import matches_in
    rng = np.random.default_rng(7)
    table = rng.integers(0, 12, (300, 4))
    query = np.concatenate([rng.permuted(table[:100], axis=1), rng.integers(0, 12, (400, 4))])
    both = np.concatenate([query, table])
    want = counts_by_sorting(both)[:len(query)] - counts_by_sorting(query)
    assert (matches_in(query, table) == want).all()
    assert (matches_in(query, table[:0]) == 0).all()
