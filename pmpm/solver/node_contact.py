"""Node-to-surface contact between FEM bodies: the free-surface nodes of one body are kept
out of the free faces of the other by a velocity constraint with Coulomb friction, with
the search, face geometry, mass sharing and MPI sums of particle-to-surface contact
(pmpm.solver.surface_contact, seed 004 Sec. 3; the seed does not describe FEM-to-FEM
contact, its notes Sec. 1.3 suggest this: FE surface nodes as the slaves).

* Which bodies: a pair of FEM bodies whose coupling (``contact.pairs[i].coupling``, else
  ``contact.coupling``) is ``surface``. The pair's ``normal`` chooses the masters: a body
  of the pair (its faces are the masters, the other's nodes the slaves: one direction),
  ``stiffer`` (the stiffer body's faces) or ``average`` (the default: both directions).
  Two rigid bodies do not meet.
* One symmetric pass, not two: every slave node of either body finds its master face in
  the same search at the same trial state, and every pair is solved at once (Jacobi).
  Two passes in turn would depend on which body goes first (the second pass sees the
  first's correction); the symmetric pass gives the same answer with the bodies' names
  swapped. That two pairs (A's node on B's face and B's node on A's face) then correct
  one meeting twice is what the mass sharing below takes care of.
* Slaves: the nodes of the free faces of a slave body (over all ranks: a node counts
  when any holder has a free face on it), each computed on its lowest holder (the rank
  that counts it). Masters: the free faces of a master body, as
  ``SurfaceContact.refresh_faces`` finds them.
* Search, every step, at the trial positions (the nodes have moved, x^(k+1) =
  x^k + dt v^(k+1/2)): the buckets of particle-to-surface contact, each face entered in
  the buckets of its box grown by its depth (half its element's size), a small
  tolerance and how far nodes moved in the step, body by body (a slave body's nodes
  search buckets of only the faces they meet); per slave node the nearest face it has
  crossed, g < 0, its foot inside the face, approaching it or not, no deeper than the
  face's depth plus what node and face moved in the step (a node that crossed faster
  than the depth is deep is still found), and within the face's depth of it at the
  step's start (the far faces of a body, and a face that a node crossing a thin body
  reaches from behind, are not taken: pmpm.kernels.node_contact.find_node_pairs).
  Before issue 24 Sec. 4 only approaching nodes within the depth were found: a node
  left inside that no longer approached stayed there, and one that crossed more than
  the depth in a step went through unseen.
* Impulse (pmpm.kernels.node_contact.node_impulse): for an approaching pair the normal
  impulse raises the relative normal velocity by min(-u.n, -g/dt), so the node lands on
  the face at the end of the step (a pair found at a distance in particle contact would
  stop early; a node that is met only when it crosses is not); the tangent sticks up to
  mu times the normal impulse. The slave takes -I on its velocity, each node J of the
  face phi_J I; the positions move by dt times the velocity changes. A node left inside
  by the Jacobi pass (rare), or inside a face it does not approach, is moved out by
  GAP_CLOSURE of its depth, by a position impulse shared like the impulse (the
  mass-weighted mean position is kept). ``largest_penetration``: the deepest node of the
  step (trial positions, before the correction); ``deepest_node``: of the run, over all
  ranks (summary.json ``node_contact.largest_penetration``).
* Mass sharing: a node lends each of its pairs the share w / Phi of its mass, w its
  weight in the pair (1 as the slave, phi_J as a master node) and Phi the sum of its
  weights over all its pairs. Two meshes that match node for node meet as two
  pairs per node pair (A's node on B's face, B's node on A's face), each with half of
  each node's mass: together they make the full stick impulse of the two nodes, as a
  single pass would. Momentum is exact: every impulse on a slave is taken by the
  face's nodes, and every node takes the full sum of its rows.

MPI: elements live on the rank of their centroid's slab; a node is held by every rank
holding one of its elements. Each step every rank sends copies of its master faces whose
box, grown by the face's depth and its nodes' move, meets the box of another rank's
slave nodes of a body that touches the face's, grown by their move (one allgather of
per-body boxes, then the faces packed to the ranks whose boxes meet, known to every rank
from the boxes: pmpm.solver.contact_halo); each pair is computed on the rank that counts
its slave node. The Phi sums go to each node's lowest holder and back, and the
rows of the impulses (slave and master nodes alike) to every holder of the node, all
summed in (node id, slave node id) order (pmpm.solver.contact_sums): every copy of a
node takes the same total, and 1 rank agrees with N to round-off.
"""
import numpy as np

from ..comm.shared_nodes import sum_shared_rows
from ..kernels import node_contact as knc
from ..kernels import surface_contact as ksc
from ..kernels.portable import cube_roots
from .contact import SURFACE_COUPLING
from .contact_halo import body_boxes, exchange_halo, grown
from .contact_sums import pad_holders, sums_at_home, sums_in_order, sums_at_holders
from .couplings import Coupling, kept_copy
from .errors import SetupError
from .fem_grid import grid_coupled_bodies
from .surface_contact import (MAX_BUCKETS, mesh_faces,
                              SegmentRows, segment_boxes, shapes)

#: the share of a depth left after the impulses that a pair closes in a step, by moving
#: the positions (not the velocities: no energy, no momentum)
GAP_CLOSURE = 0.5
#: a node may cross a face by at most this share of the face's element size
DEPTH_SHARE = 0.5
#: in cells: how far a node must have crossed a face to meet it, and how far beside the
#: face (in its plane) it may lie (round-off: a node on a face's edge lies in the plane
#: of the side face too)
TOLERANCE = 1e-10
SEGMENT_FIELDS = ("gid", "x", "x0", "v", "inv_m", "body", "key", "holders", "depth")
#: the width of the search's buckets in mean element edges of the master faces
BUCKET_EDGES = 2.0


def node_contact_pairs(rules, fem_bodies, rigid):
    """(nb, nb) bool: ``[a, b]`` when the free-surface nodes of FEM body a are slaves
    against the free faces of FEM body b (see the module docstring)."""
    nb = len(rules.coupling)
    fem = np.zeros(nb, bool)
    fem[list(fem_bodies)] = True
    rigid = np.asarray(rigid, bool)
    pair = (rules.coupling == SURFACE_COUPLING) & fem[:, None] & fem[None, :] \
        & ~(rigid[:, None] & rigid[None, :]) & ~np.eye(nb, dtype=bool)
    master = rules.master
    return pair & ((master == -1) | (master == np.arange(nb)[None, :]))


def check_node_contact(config, rules, touches):
    """SetupError naming the key of a pair of FEM bodies in node-to-surface contact of
    which one also meets particle bodies on the grid (CFEMP moves its nodes through the
    grid contact; the two together are not validated)."""
    names = [b.name for b in config.bodies]
    coupled = grid_coupled_bodies(rules, [b.is_fem for b in config.bodies])
    problems = []
    for a, b in zip(*np.nonzero(np.triu(touches | touches.T))):
        if coupled[a] or coupled[b]:
            key = next((f"contact.pairs[{i}].coupling" for i, pair in
                        enumerate(config.contact.pairs)
                        if set(pair.bodies) == {names[a], names[b]}), "contact.coupling")
            problems.append(f"{key}: FEM bodies '{names[a]}' and '{names[b]}' meet by "
                            f"node-to-surface contact, but "
                            f"'{names[a] if coupled[a] else names[b]}' meets particle "
                            f"bodies on the grid (CFEMP); the two are not supported "
                            f"together: use surface coupling for its particle pairs")
    if problems:
        raise SetupError(problems)


class NodeContact(Coupling):
    """Node-to-surface contact of the FEM bodies that meet with SURFACE_COUPLING.

    Parameters
    ----------
    rules : solver.contact.ContactRules   ``coupling``, ``master`` and ``friction``
    world : comm.World
    elements : solver.fem_bodies.FemBodies
    grid : grid.CoarseGrid   (the cell, for the tolerances)
    """

    def __init__(self, rules, world, elements, grid):
        self.world, self.elements = world, elements
        self.touches = node_contact_pairs(rules, elements.body_indices,
                                          elements.materials.rigid)
        self.masters, self.slave_bodies = self.touches.any(axis=0), self.touches.any(axis=1)
        self.friction = np.ascontiguousarray(rules.friction, np.float64)
        self.off_tol = TOLERANCE * grid.h
        self.last_pairs, self.largest_penetration, self.deepest = 0, 0.0, 0.0
        self.force_log = None          # pmpm.solver.forces.ForceLog, set by the simulation
        self.start_x = None
        self.segment_rows = SegmentRows()
        self.refresh_faces()

    @property
    def active(self):
        return bool(self.touches.any())

    def after_elements_changed(self):
        self.refresh_faces()

    # -- the slaves and the master segments ------------------------------------------
    def refresh_faces(self):
        """The master faces and the slave nodes of this rank's elements (collective
        among the ranks that share nodes); call again whenever the elements it holds
        change."""
        fem = self.elements
        faces, key, free, self.holders = mesh_faces(self.world, fem)
        face_body = np.repeat(fem.body, 6)
        keep = free & self.masters[face_body]
        self.face_nodes = np.ascontiguousarray(faces[keep])
        self.face_key = key[keep]
        inv_m = np.where(fem.fixed.all(axis=1), 0.0, 1.0 / fem.mass)
        inv_m[fem.rigid_nodes()] = 0.0
        self.inv_m = inv_m
        self.face_inv_m = inv_m[self.face_nodes]
        self.face_gid = fem.node_id[self.face_nodes]
        self.face_body = fem.node_body[self.face_nodes[:, 0]].astype(np.int64)
        self.face_holders = self.holders[self.face_nodes]
        size = cube_roots(np.ascontiguousarray(np.repeat(fem.vol0, 6)[keep], np.float64))
        self.face_depth = DEPTH_SHARE * size
        self.slaves = self.slave_nodes(faces, free & self.slave_bodies[face_body])
        self.node_body = fem.node_body.astype(np.int64)
        # the search goes body by body: each slave body's nodes look only at the faces
        # it meets, in their order (a face of another body fails the kernel's first
        # test, so the pairs are the same), and a node far from all of them falls
        # outside their buckets at once
        slave_body = self.node_body[self.slaves]
        self.slave_groups = [(b, np.flatnonzero(slave_body == b))
                             for b in np.unique(slave_body)]

    def slave_nodes(self, faces, surface):
        """Local indices of the nodes this rank counts that lie on a free face of a
        slave body, here or on any other holder (collective among the sharers)."""
        fem = self.elements
        marked = np.zeros((len(fem.x), 1))
        marked[faces[surface].ravel(), 0] = 1.0
        marked = sum_shared_rows(self.world, marked, fem.partners)
        return np.flatnonzero((marked[:, 0] > 0) & fem.owned)

    def own_segments(self):
        fem = self.elements
        fixed = {"gid": self.face_gid, "inv_m": self.face_inv_m, "body": self.face_body,
                 "key": self.face_key, "holders": self.face_holders,
                 "depth": self.face_depth}
        return self.segment_rows.own(fixed, fem.x, self.start_x, fem.v, self.face_nodes)

    def with_halo(self, own, node_move):
        """Own segments plus copies of the other ranks' segments whose box, grown by
        their depth and how far their nodes moved in the step, meets the box of this
        rank's slave nodes of a body they touch, grown by how far those moved
        (collective; pmpm.solver.contact_halo)."""
        if self.world.size == 1:
            return own
        x = self.elements.x[self.slaves]
        grow = node_move.max(initial=0.0)
        lo, hi = np.empty((len(own["x"]), 3)), np.empty((len(own["x"]), 3))
        knc.segment_boxes(own["x"], own["depth"] + self.off_tol
                          + segment_moves(own["x"], own["x0"]), lo, hi)
        slaves = grown(body_boxes(x, x, self.node_body[self.slaves], len(self.touches)),
                       grow)
        received = exchange_halo(self.world, own, SEGMENT_FIELDS, lo, hi, slaves,
                                 self.touches)
        me = self.world.rank
        return self.segment_rows.joined(received[:me] + received[me + 1:])

    # -- the step ---------------------------------------------------------------------
    def after_scatter(self, grids, kinds):
        """Keep the nodes' start-of-step positions: the search tells from them on which
        side of a face a node that is now behind it was."""
        self.start_x = kept_copy(self.start_x, self.elements.x)

    def slave_moves(self):
        """How far each slave node moved in the step so far."""
        moves = np.empty(len(self.slaves))
        ksc.point_moves(self.elements.x, self.start_x, self.slaves, moves)
        return moves

    def after_update_points(self, dt):
        node_move = self.slave_moves()
        segs = self.with_halo(self.own_segments(), node_move)
        pair_n, pair_s, geo = self.find_pairs(segs, node_move)
        phi = shapes(geo[:, 0], geo[:, 1])
        fem = self.elements
        slave_phi, seg_phi = self.phi_sums(segs, pair_n, pair_s, phi)
        lent = np.zeros(len(fem.x))
        lent[pair_n] = self.inv_m[pair_n] * slave_phi
        impulses, depth = np.zeros((len(pair_n), 3)), np.zeros(len(pair_n))
        seg_lent = segs["inv_m"] * seg_phi
        knc.node_pair_impulses(pair_n, pair_s, geo, lent, fem.v, self.node_body,
                               segs["v"], seg_lent, segs["body"],
                               self.friction, dt, impulses, depth)
        if self.force_log is not None:       # before the pushes change the velocities
            self.force_log.surface_pairs(
                self.node_body[pair_n], segs["body"][pair_s], impulses, geo[:, 2:5],
                fem.v[pair_n] - np.einsum("kj,kjd->kd", phi, segs["v"][pair_s]),
                lent[pair_n] + np.einsum("kj,kj->k", phi, seg_lent[pair_s]))
        shifts = GAP_CLOSURE * np.maximum(depth, 0.0)[:, None] * geo[:, 2:5]
        self.push_nodes(segs, pair_n, pair_s, phi, impulses, shifts, dt)
        self.last_pairs = int(np.count_nonzero(depth >= 0.0))
        self.largest_penetration = float(-geo[:, 5].min()) if len(geo) else 0.0
        self.deepest = max(self.deepest, self.largest_penetration)

    def deepest_node(self):
        """The deepest slave node found behind a master face so far in the run (at the
        trial positions, before the correction), over all ranks (collective)."""
        return self.world.max(self.deepest)

    def find_pairs(self, segs, node_move):
        """(local slave node index, segment index, geometry (xi, eta, n, g)) of every
        slave node that has crossed a master face, approaching it or not; each face's box
        is grown by its depth plus the farthest any slave node here and any of its nodes
        moved in the step (kernel ``find_node_pairs``)."""
        fem = self.elements
        if not len(segs["key"]) or not len(self.slaves):
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 6))
        x, x0 = np.ascontiguousarray(segs["x"]), np.ascontiguousarray(segs["x0"])
        seg_move = segment_moves(x, x0)
        seg_lo, seg_hi, _, _ = segment_boxes(
            x, segs["depth"] + self.off_tol + seg_move + node_move.max())
        # two edges: a slave body's nodes meet the faces of other bodies only, few of
        # them by any one bucket, so wide buckets cost little in the search and save
        # entries (a face in about 8 rather than 27 buckets)
        size = BUCKET_EDGES * np.linalg.norm(x[:, 1] - x[:, 0], axis=1).mean()
        n = len(self.slaves)
        pair_seg, geo = np.full(n, -1, np.int64), np.empty((n, 6))
        for body, group in self.slave_groups:
            faces = np.flatnonzero(self.touches[body][segs["body"]])
            if not len(faces):
                continue
            nodes = self.slaves[group]
            found_seg, found_geo = np.empty(len(group), np.int64), np.empty((len(group), 6))
            lo, inv_size, dims, start, items = face_buckets(seg_lo, seg_hi, faces, size)
            knc.find_node_pairs(fem.x[nodes], self.start_x[nodes], node_move[group],
                                self.node_body[nodes], x, x0, seg_move, segs["body"],
                                segs["key"], np.ascontiguousarray(segs["depth"]),
                                self.touches, self.off_tol, lo, inv_size, dims, start,
                                items, found_seg, found_geo)
            pair_seg[group], geo[group] = found_seg, found_geo
        found = np.flatnonzero(pair_seg >= 0)
        return self.slaves[found], pair_seg[found], geo[found]

    def phi_sums(self, segs, pair_n, pair_s, phi):
        """Per pair its slave node's Phi, and (ns, 4) per segment node its Phi: the sum
        of the node's weights over the pairs of all ranks (1 as a slave,
        phi_J as a master node; 0 where it has none), summed on the node's lowest
        holder in (node id, slave node id) order."""
        fem = self.elements
        slave_gid = fem.node_id[pair_n]
        gid = np.concatenate([slave_gid, segs["gid"][pair_s].ravel()])
        key = np.concatenate([slave_gid, np.repeat(slave_gid, 4)])
        rows = np.concatenate([np.ones(len(pair_n)), phi.ravel()])
        if self.world.size == 1:
            ids, total = sums_in_order(gid, key, rows)
        else:
            home = np.concatenate([np.full(len(pair_n), self.world.rank),
                                   segs["holders"][pair_s][:, :, 0].ravel()])
            ids, total = sums_at_home(self.world, gid, key, rows, home)
        seg_phi = np.zeros(segs["gid"].shape)
        used = np.unique(pair_s)
        seg_phi[used] = lookup(ids, total, segs["gid"][used].ravel()).reshape(-1, 4)
        return lookup(ids, total, slave_gid), seg_phi

    def push_nodes(self, segs, pair_n, pair_s, phi, impulses, shifts, dt):
        """The slave takes -I and the position impulse +Q, each face node J phi_J I and
        -phi_J Q, at every holder of the node, summed there in (node id, slave node id)
        order; the free components of velocities and positions move."""
        fem = self.elements
        slave_gid = fem.node_id[pair_n]
        gid = np.concatenate([slave_gid, segs["gid"][pair_s].ravel()])
        key = np.concatenate([slave_gid, np.repeat(slave_gid, 4)])
        pushes = np.hstack([impulses, -shifts])
        rows = np.concatenate([-pushes, (phi[:, :, None] * pushes[:, None, :]).reshape(-1, 6)])
        width = max(self.holders.shape[1], segs["holders"].shape[2])
        holders = np.concatenate([
            pad_holders(self.holders[pair_n], width),
            pad_holders(segs["holders"][pair_s], width).reshape(-1, width)])
        nodes, total = sums_at_holders(self.world, gid, key, rows, holders, fem.node_id)
        total = total.reshape(len(nodes), 2, 3)
        total[fem.fixed[nodes, None, :].repeat(2, axis=1)] = 0.0
        total[fem.rigid_nodes()[nodes]] = 0.0
        before = fem.v.copy()
        fem.v[nodes] += total[:, 0] / fem.mass[nodes, None]
        fem.hold_at_faces(None)            # a node on a fixed or slip grid face stays held
        move = dt * (fem.v - before)
        move[nodes] += total[:, 1] / fem.mass[nodes, None]
        fem.x += move


def face_buckets(seg_lo, seg_hi, faces, size):
    """The buckets of the faces ``faces`` (indices, ascending) with the grown boxes
    [seg_lo, seg_hi]: (lo, 1 / size, dims, start, items), items the face indices, each
    bucket's in ascending order; a bucket is ``size`` wide, or wider where MAX_BUCKETS
    would not cover the faces."""
    lo, hi = np.empty(3), np.empty(3)
    face_lo, face_hi = seg_lo[faces], seg_hi[faces]
    ksc.box_bounds(face_lo, face_hi, lo, hi)
    extent = hi - lo
    size = max(size, float(np.prod(extent) / MAX_BUCKETS) ** (1 / 3))
    dims = np.maximum(np.ceil(extent / size).astype(np.int64), 1)
    start, items = ksc.bucket_segments(face_lo, face_hi, lo, 1.0 / size, dims)
    return lo, 1.0 / size, dims, start, faces[items]


def segment_moves(seg_x, seg_x0):
    """Per segment the farthest any of its nodes moved in the step."""
    moves = np.empty(len(seg_x))
    ksc.segment_moves(np.ascontiguousarray(seg_x), np.ascontiguousarray(seg_x0), moves)
    return moves


def lookup(ids, total, wanted):
    """``total`` of each id of ``wanted`` in the sorted ``ids`` (0 where absent)."""
    if not len(ids):
        return np.zeros(len(wanted))
    at = np.minimum(np.searchsorted(ids, wanted), len(ids) - 1)
    return np.where(ids[at] == wanted, total[at], 0.0)
