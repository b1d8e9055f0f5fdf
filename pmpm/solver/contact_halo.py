"""The halo of the FEM contacts' master segments: which of its segments a rank copies to
which other ranks each step (particle-to-surface contact, pmpm.solver.surface_contact,
and node-to-surface contact, pmpm.solver.node_contact).

A segment of master body B can pair only with a slave point (a particle, or an FE node)
of a body b that ``touches[b, B]``, and only where the point lies within the segment's
reach. So each rank gathers, per body, the box of its slave points grown by the points'
part of the reach, and the box of its segments grown by theirs, from every rank (one
allgather of a few boxes); a segment goes to rank r when its grown box meets the box of
one of r's slave bodies that touches its body. Every rank knows from the same boxes who
sends to whom, so the segments go without a barrier (pmpm.comm.sparse.exchange_known).

Per body, not per rank: in the perforation the plate's nodes are slaves over the whole
plate, but the plate's faces need go only where the rod's nodes and the converted
particles are (a few hundred faces of the 2 mm model, not the strip along the slab plane:
2,000 a step before, in two contacts). Which segments a rank receives changes only which
faces it may search, never which pair a point finds (the search takes the nearest face,
ties to the smaller key, of those within its reach: all of them are sent).
"""
import numpy as np

from ..comm.sparse import exchange_known
from ..kernels import surface_contact as ksc

#: a box that meets nothing
EMPTY_BOX = (np.inf, -np.inf)


def body_boxes(lo, hi, body, n_bodies):
    """(n_bodies, 2, 3): per body the box of the rows of ``lo``, ``hi`` (n, 3) whose
    ``body`` it is; lo = inf, hi = -inf (an empty box, meeting nothing) where it has no
    row."""
    boxes = np.empty((n_bodies, 2, 3))
    boxes[:, 0], boxes[:, 1] = EMPTY_BOX
    ksc.body_box_bounds(np.ascontiguousarray(lo), np.ascontiguousarray(hi),
                        np.ascontiguousarray(body, np.int64), boxes)
    return boxes


def grown(boxes, pad):
    """The boxes (n, 2, 3) grown by ``pad`` on every side (empty boxes stay empty)."""
    out = boxes.copy()
    out[:, 0] -= pad
    out[:, 1] += pad
    return out


def meeting_pairs(segment_boxes, slave_boxes, touches):
    """The (slave body b, master body B) pairs with ``touches[b, B]`` whose boxes meet:
    ``slave_boxes[b]`` and ``segment_boxes[B]`` (per-body boxes, (n_bodies, 2, 3))."""
    b, B = np.nonzero(touches)
    seg, slave = segment_boxes[B], slave_boxes[b]
    meet = np.all((seg[:, 1] >= slave[:, 0]) & (seg[:, 0] <= slave[:, 1]), axis=1)
    return b[meet], B[meet]


def sends(segment_boxes, slave_boxes, touches):
    """Whether a rank with the per-body ``segment_boxes`` has segments for a rank with
    the per-body ``slave_boxes``: some slave body touching some master body whose boxes
    meet."""
    return len(meeting_pairs(segment_boxes, slave_boxes, touches)[0]) > 0


def exchange_halo(world, own, fields, seg_lo, seg_hi, slave_boxes, touches):
    """The other ranks' segments that may pair with this rank's slave points, by source
    rank as pmpm.comm.sparse.exchange_arrays returns them (collective).

    Parameters
    ----------
    own : dict of this rank's segment fields (rows: segments), ``own["body"]`` the
        master body of each
    fields : the fields sent
    seg_lo, seg_hi : (ns, 3) each segment's box grown by the segment's part of the reach
    slave_boxes : (n_bodies, 2, 3) per slave body the box of this rank's slave points
        grown by the points' part of the reach (empty where it has none)
    touches : (n_bodies, n_bodies) bool, [slave body, master body]
    """
    body = np.ascontiguousarray(own["body"], np.int64)
    mine = body_boxes(seg_lo, seg_hi, body, len(touches))
    boxes = world.allgather((slave_boxes, mine))
    me = world.rank
    packages = []
    packages, to = [], []
    for r, (theirs, _) in enumerate(boxes):
        going = np.zeros(len(body), np.bool_)
        if r != me:
            slaves, masters = meeting_pairs(mine, theirs, touches)
            for b, B in zip(slaves, masters):
                ksc.mark_rows_meeting(seg_lo, seg_hi, body, B, theirs[b], going)
            if len(slaves):
                to.append(r)
        packages.append({k: own[k][going] for k in fields})
    by = [r for r in range(len(boxes))
          if r != me and sends(boxes[r][1], slave_boxes, touches)]
    return exchange_known(world, packages, to, by)
