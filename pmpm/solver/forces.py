"""Force histories: the contact force between each pair of bodies and the reaction of
each constrained face of the grid box and of each FEM body's constrained nodes
(``forces.csv``, LS-DYNA's rcforc and bndout), as the mean force over the interval
since the previous history row, so that a column integrated over the run is the exact
impulse.

The impulses are measured, not modelled: what a node gives the particles reaching it
less the force of their own stresses, gravity and loads (``pmpm.kernels.forces``); for
the surface couplings, the pair impulses themselves; for FE nodes, their velocity change
less that of their forces. So a striker's contact force integrated over the impact is its
momentum change, and a block at rest on a floor presses on it with its weight.

Attribution rules worth knowing:

* grid contact: a body's correction at a contact node counts against the heaviest other
  body there (the one it was made against); a rigid body's force is the opposite of the
  force on its partner;
* faces: each component of a node's impulse goes to the face of that axis the node lies
  on or beyond, else to a fixed face or wall it lies on, else to the plane of symmetry
  it mirrors across (so the tangential parts of a mirrored group, which cancel, stay on
  one face);
* dissipated energy (``A/B.dissipated``, ``x-.dissipated``: cumulative since the start,
  unlike the forces): the work of the impulses against the motion they leave
  (:mod:`pmpm.kernels.forces`), which only friction makes nonzero; their sum is
  history.csv's ``dissipated``;
* a face node that is also a contact node is counted with the shared field's motion, and
  with refined windows the tied slave nodes (whose motion is their masters') are not
  counted: both are approximations near such nodes only.
"""
import numpy as np

from ..kernels import exact_sum
from ..kernels import forces as kf
from ..kernels.mpm import NODAL_COMPONENTS
from ..kernels.tied import mark_slaves
from .contact import start_shares
from .couplings import Coupling
from .observe import exact_totals

FACE_NAMES = ("x-", "x+", "y-", "y+", "z-", "z+")


class ForceLog(Coupling):
    """Accumulates, over ranks and steps, the impulses between body pairs (``pair``:
    n_bodies x n_bodies x kf.PAIR_WIDTH, on the first body from the second), on the
    material from the box faces (``face``: 6 x kf.FACE_WIDTH) and on each FEM body from
    its constrained nodes (``support``: n_bodies x 3) since the last history row, with
    the energy the pairs and faces dissipated; ``dissipated_pair`` (n_bodies x
    n_bodies) and ``dissipated_face`` (6) are those energies since the start, the same
    on every rank.

    It runs after the other couplings (it reads their end-of-step fields)."""

    def __init__(self, config, world, bodies, m_tiny, grid_contact=None):
        self.world, self.m_tiny = world, m_tiny
        n = len(bodies.names)
        self.names = list(bodies.names)
        self.rigid = np.asarray(bodies.grid_rigid, bool)
        self.share = 1.0 if config.time.transfer == "apic" else float(config.time.pic)
        self.body_share = np.asarray(start_shares(config), np.float64)
        self.grid_contact = grid_contact
        self.faces = [f for f, name in enumerate(FACE_NAMES)
                      if config.grid.boundary[name] != "free"]
        self.fem_supported = []
        #: with exact sums each value is an exact accumulator (pmpm.kernels.exact_sum):
        #: the kernels add each node's and pair's impulse exactly, so that a row has the
        #: same bits on any rank count
        self.exact = bool(config.grid.exact_sums)
        sums = exact_sum.zeros if self.exact else np.zeros
        self.pair = sums((n, n, kf.PAIR_WIDTH))
        self.face = sums((6, kf.FACE_WIDTH))
        self.support = sums((n, 3))
        self.dissipated_pair = np.zeros((n, n))
        self.dissipated_face = np.zeros(6)
        self.since = 0.0                    # the time of the previous history row
        self.zones = {}
        self.zone_keys = {}
        self.slave_masks = {}               # level index (None: no ties) -> int8 mask

    # -- the step's hooks ------------------------------------------------------------
    def before_reflect(self, grids, what):
        """Keep the raw mass and momentum (``what`` "nodal") or force ("force") of the
        nodes a face may push, after the shared-plane sums and before the reflection."""
        for s in grids:
            if what == "nodal":
                self.zones[s.index] = self.face_zone(s)
            nodes, face_of, count, raw = self.zones[s.index]
            if what == "nodal":
                kf.keep_rows(nodes, count, s.nodal, 0, raw)
            else:
                kf.keep_rows(nodes, count, s.force, 5, raw)

    def face_zone(self, s):
        """The level's zone (:func:`pmpm.kernels.forces.face_zone`), kept while its block
        stays the same (blocks are rebuilt every step, but seldom change)."""
        b = s.block
        key = (tuple(b.lo), tuple(b.shape), tuple(b.shared_planes), len(s.mirror))
        kept = self.zone_keys.get(s.index)
        if kept is not None and kept[0] == key:
            return kept[1]
        zone = self.new_zone(s)
        self.zone_keys[s.index] = (key, zone)
        return zone

    def new_zone(self, s):
        b = s.block
        n_nodes = b.n_nodes
        nodes = np.empty(n_nodes, np.int64)
        face_of = np.empty(n_nodes, np.int64)
        if not self.faces:
            return nodes, face_of, 0, np.zeros((0, kf.RAW_WIDTH))
        per_plane, counted = counted_planes(b, self.world.rank)
        count = kf.face_zone(s.nodes.faces, s.mirror, counted, per_plane, nodes, face_of)
        return nodes, face_of, count, np.empty((count, kf.RAW_WIDTH))

    def after_integrate(self, grids, dt):
        for s in grids:
            nodes, face_of, count, raw = self.zones[s.index]
            slave = self.tied_slaves(s)
            if count:
                kf.face_impulses(nodes, face_of, count, raw, s.gvel, s.gnew, s.nodes,
                                 self.share, dt, self.m_tiny, slave, self.face)
            if self.grid_contact is not None:
                f = self.grid_contact.fields[s.index]
                if f.n_slots:
                    per_plane, counted = counted_planes(s.block, self.world.rank)
                    kf.contact_impulses(f.slots(), f.real_mass, self.body_share, self.rigid,
                                        s.nodes.faces, counted, per_plane, dt, self.m_tiny,
                                        slave, self.pair)

    def tied_slaves(self, s):
        """Per node of level ``s``, 1 at this step's tied slaves (a window's interface
        nodes, the coarse nodes just inside it): their motion is interpolated from their
        masters, so what they seem to be given is the tie's, not a face's or contact's."""
        n_nodes = s.block.n_nodes
        ties = getattr(s, "slave_ties", None)
        kept = self.slave_masks.get(s.index if ties else None)
        if kept is None or len(kept) < n_nodes:        # kept between steps: no allocation
            kept = np.zeros(max(n_nodes, 1024) * 5 // 4, np.int8)
            self.slave_masks[s.index if ties else None] = kept
        slave = kept[:n_nodes]
        if ties:
            slave.fill(0)
            for t in ties:
                mark_slaves(t, slave)
        return slave

    # -- from the other couplings and the FEM bodies ---------------------------------
    def surface_pairs(self, first, second, impulses, normals, relative, inverse_mass):
        """Pair k gave body ``first[k]`` -impulses[k] and body ``second[k]`` (the owner
        of the face with outward normal ``normals[k]``) +impulses[k]; ``relative[k]``
        is the first body's velocity less the face point's before the impulse and
        ``inverse_mass[k]`` the pair's (:func:`pmpm.kernels.forces.surface_pair_work`)."""
        if len(impulses):
            impulses = np.ascontiguousarray(impulses, np.float64)
            work = kf.surface_pair_work(impulses, relative, inverse_mass)
            kf.pair_impulses(np.asarray(first, np.int64), np.asarray(second, np.int64),
                             impulses, np.ascontiguousarray(normals, np.float64),
                             np.ascontiguousarray(work), self.pair)

    # -- a history row ---------------------------------------------------------------
    def take_row(self, time):
        """The mean forces since the previous row (collective): a dict of column name ->
        value, in the column order of :meth:`columns`; the accumulators restart."""
        pair, face, support = self.totals()
        self.dissipated_pair += pair[:, :, 7]
        self.dissipated_face += face[:, 3]
        span = time - self.since
        scale = 1.0 / span if span > 0.0 else 0.0
        values = []
        for a, b in self.pairs():
            row = -pair[b, a] if self.rigid[a] else pair[a, b]
            if self.rigid[a]:
                row[3] = pair[b, a, 3]
            values += [*row[:3], row[3], float(np.linalg.norm(row[4:7]))]
        for f in self.faces:
            values += list(face[f, :3])
        for b in self.fem_supported:
            values += list(support[b])
        scaled = [scale * v for v in values]
        for a, b in self.pairs():
            scaled.append(self.dissipated_pair[a, b] + self.dissipated_pair[b, a])
        scaled += [self.dissipated_face[f] for f in self.faces]
        self.pair[:] = 0
        self.face[:] = 0
        self.support[:] = 0
        self.since = time
        return scaled

    def totals(self):
        """(pair, face, support) since the last row, summed over the ranks
        (collective): exactly with exact sums (one allgather of the partials), else
        one SUM reduction."""
        arrays = (self.pair, self.face, self.support)
        if self.exact:
            return tuple(exact_totals(self.world, arrays))
        sums = self.world.sum(np.concatenate([a.ravel() for a in arrays]))
        ends = np.cumsum([a.size for a in arrays])[:-1]
        return tuple(s.reshape(a.shape) for s, a in zip(np.split(sums, ends), arrays))

    @property
    def dissipated(self):
        """The energy contact, friction and the faces have dissipated since the start
        (at the last row; the same on every rank)."""
        return float(self.dissipated_pair.sum() + self.dissipated_face.sum())

    def pairs(self):
        n = len(self.names)
        return [(a, b) for a in range(n) for b in range(a + 1, n)
                if not (self.rigid[a] and self.rigid[b])]

    def columns(self):
        cols = []
        for a, b in self.pairs():
            pair = f"{self.names[a]}/{self.names[b]}"
            cols += [f"{pair}.{c}" for c in ("fx", "fy", "fz", "normal", "tangential")]
        for f in self.faces:
            cols += [f"{FACE_NAMES[f]}.{c}" for c in ("fx", "fy", "fz")]
        for b in self.fem_supported:
            cols += [f"{self.names[b]}.support.{c}" for c in ("fx", "fy", "fz")]
        cols += [f"{self.names[a]}/{self.names[b]}.dissipated" for a, b in self.pairs()]
        return cols + [f"{FACE_NAMES[f]}.dissipated" for f in self.faces]

    # -- restart ---------------------------------------------------------------------
    def state(self):
        """The impulses since the last row, summed over the ranks (collective), so that a
        restart on any number of ranks continues the interval."""
        pair, face, support = self.totals()
        state = {"since": self.since, "pair": pair.tolist(), "face": face.tolist(),
                 "support": support.tolist(),
                 "dissipated_pair": self.dissipated_pair.tolist(),
                 "dissipated_face": self.dissipated_face.tolist()}
        if self.exact:          # the exact sums themselves: a restart continues them
            state["bins"] = [self.world.sum(a).tolist()
                             for a in (self.pair, self.face, self.support)]
        return state

    def restore(self, state):
        """Rank 0 takes the saved sums, the others start from zero; every rank takes
        the energies dissipated so far."""
        if state:
            self.since = state["since"]
            self.dissipated_pair[:] = state.get("dissipated_pair", 0.0)
            self.dissipated_face[:] = state.get("dissipated_face", 0.0)
            if self.world.is_root:
                face = np.asarray(state["face"])      # 3 wide before the energies
                if not self.exact:
                    self.pair[:] = state["pair"]
                    self.face[:, :face.shape[1]] = face
                    self.support[:] = state["support"]
                    return
                bins = state.get("bins")
                if bins is not None:
                    for acc, saved in zip((self.pair, self.face, self.support), bins):
                        acc[:] = np.asarray(saved, np.int64)
                    return
                full = np.zeros(self.face.shape[:-1])
                full[:, :face.shape[1]] = face
                for acc, saved in ((self.pair, state["pair"]), (self.face, full),
                                   (self.support, state["support"])):
                    exact_sum.add_rows(acc.reshape(-1, exact_sum.WIDTH), 0,
                                       np.asarray(saved, np.float64).reshape(-1, 1))


def counted_planes(block, rank):
    """(nodes per slab plane, bool per local plane): the planes this rank counts, all
    but those it shares with the rank below (which counts them)."""
    n_planes = int(block.shape[block.slab_axis])
    counted = np.ones(max(n_planes, 1), np.bool_)
    for neighbour, (first, stop) in block.shared_planes:
        if neighbour < rank:
            counted[first:stop] = False
    return block.n_nodes // max(n_planes, 1), counted


assert NODAL_COMPONENTS >= 5          # mass, momentum (3), rigid mass come first
