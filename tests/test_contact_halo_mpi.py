"""The FEM contacts' segment halo (pmpm.solver.contact_halo, issue 24's 2-rank
efficiency): a segment goes to a rank only where its grown box meets the box of that
rank's slave points of a body that touches the segment's body; both sides agree on who
sends to whom from the gathered boxes. Serially: the per-body boxes and the rank test;
on 2 ranks: what arrives."""
import numpy as np
import pytest

from pmpm.solver.contact_halo import body_boxes, exchange_halo, grown, sends

FIELDS = ("key", "body")


def test_body_boxes_are_per_body_and_empty_where_a_body_has_no_row():
    lo = np.array([[0.0, 0, 0], [2, 1, 1], [5, 5, 5]])
    boxes = body_boxes(lo, lo + 1.0, np.array([0, 0, 2]), 3)
    assert np.array_equal(boxes[0], [[0, 0, 0], [3, 2, 2]])
    assert np.all(boxes[1, 0] == np.inf) and np.all(boxes[1, 1] == -np.inf)
    assert np.array_equal(grown(boxes, 0.5)[2], [[4.5] * 3, [6.5] * 3])
    assert np.all(grown(boxes, 0.5)[1, 0] == np.inf)


def test_a_rank_sends_only_where_a_touching_slave_body_is_near():
    segments = body_boxes(np.zeros((1, 3)), np.ones((1, 3)), np.array([1]), 2)
    near = body_boxes(np.full((1, 3), 0.9), np.full((1, 3), 2.0), np.array([0]), 2)
    far = grown(near, -0.0) + 5.0
    touches = np.array([[False, True], [False, False]])     # body 0's points, body 1's faces
    assert sends(segments, near, touches)
    assert not sends(segments, far, touches)
    assert not sends(segments, near, touches.T)             # the wrong way round


def segments_of(rank):
    """Rank 0: segments of body 1 along x at 0, 10, 20, 30 (unit boxes); rank 1: none."""
    n = 4 if rank == 0 else 0
    lo = np.zeros((n, 3))
    lo[:, 0] = 10.0 * np.arange(n)
    own = {"key": np.arange(n, dtype=np.int64) + 100, "body": np.ones(n, np.int64)}
    return own, lo, lo + 1.0


@pytest.mark.mpi(min_size=2)
def test_the_halo_holds_the_segments_near_the_other_ranks_slaves():
    from mpi4py import MPI
    from pmpm.comm import World
    world = World(MPI.COMM_WORLD)
    own, lo, hi = segments_of(world.rank)
    touches = np.array([[False, True], [False, False]])
    # rank 1's slave points (body 0) about the segment at x = 20; rank 0 has none
    x = np.array([[20.5, 0.5, 0.5], [21.8, 0.2, 0.4]]) if world.rank == 1 else np.zeros((0, 3))
    slaves = grown(body_boxes(x, x, np.zeros(len(x), np.int64), 2), 0.5)
    received = exchange_halo(world, own, FIELDS, lo, hi, slaves, touches)
    if world.rank == 1:
        assert received[0]["key"].tolist() == [102]
    else:
        assert all(len(r["key"]) == 0 for i, r in enumerate(received) if i != 0)
    # a slave body that does not touch body 1's faces gets nothing
    received = exchange_halo(world, own, FIELDS, lo, hi, slaves, touches.T)
    assert all(len(r["key"]) == 0 for i, r in enumerate(received) if i != world.rank)
