"""Couplings: what ties the fields of the step together beyond one body on one grid.

A coupling answers the step's hooks (all optional, in step order):
``after_scatter`` (before the shared-plane sums of mass and momentum),
``before_reflect`` (after the sums of the nodal values or forces, before their
reflection across planes of symmetry), ``after_mass_sum``, ``after_velocities``, ``after_forces`` (before the force sums),
``after_integrate`` and ``after_update_points`` (the points and FE nodes have moved),
and ``after_elements_changed`` (called by the FEM kind's ``elements_changed`` event:
elements removed by a transfer at the end of a step, or moved to another rank when the
slabs were rebalanced);
and gives the point kernels its ``view`` of a level (None: the point kernels see the one
shared field). Today: the tied interface between refined windows and the coarse grid
(seed 000 Sec. 3), multi-velocity grid contact (seed 001, ``pmpm.solver.contact``) and
particle-to-surface contact with FEM bodies (seed 004, ``pmpm.solver.surface_contact``);
the simulation builds them from the registry (``pmpm.solver.registry``).
"""
import numpy as np

from ..comm.exchange import continue_shared_planes, or_shared_planes, take_marked_planes
from ..kernels import tied
from ..kernels.records import TieSet


class Coupling:
    """The no-op coupling: every hook does nothing, the view is the shared field."""

    def after_scatter(self, grids, kinds):
        pass

    def before_reflect(self, grids, what):
        """The shared-plane sums of ``what`` ("nodal" or "force") are complete; the
        reflection across planes of symmetry comes next."""

    def after_mass_sum(self, grids, kinds):
        pass

    def after_velocities(self, grids):
        pass

    def after_forces(self, grids):
        pass

    def after_integrate(self, grids, dt):
        pass

    def after_update_points(self, dt):
        pass

    def after_elements_changed(self):
        """Elements were removed (a transfer, pmpm.solver.transfer) or moved to another
        rank (a rebalance), as their kind's ``elements_changed`` says: rebuild what
        depends on the mesh (collective)."""

    def view(self, state):
        return None


class TiedInterface(Coupling):
    """Refined windows tied to the coarse grid (seed 000 Eqs. 17-24).

    The ties are linear in the nodal values, so each rank adds its own (partial) slave
    values to the master nodes *before* the shared planes are summed: a slave on a slab
    plane is then counted once on each rank with its share, a master on a slab plane gets
    every rank's share through the sum, and no value is counted twice. Slave velocities
    and accelerations are interpolated *after* the sums, from complete master values that
    every rank holding the slave has alike.

    With layer-ordered sums (``grid.exact_sums``, ``pmpm.kernels.layered``) the slaves are
    added *after* the shared-plane sums instead, from complete slave values to complete
    master values, each master's terms in slave row order (the slab axis slowest): the
    rank that owns a slave's node plane adds its term, the rank below first, and the
    masters on a slab plane are passed on from the rank below to the rank above and
    back (``continue_shared_planes``), so every rank count adds the same terms in the
    same order as one rank. An inner slave's coarse value is then complete too: every
    rank holding it and its window node adds it alike, and a rank that holds the window
    node on a shared plane without the coarse node takes the neighbour's copy.
    """

    def __init__(self, world):
        self.world = world
        self.occupied = np.zeros(0, np.int64)
        self.buffers = {}
        self.inner_buffers = {}

    def after_scatter(self, grids, kinds):
        """Find every window's tied slaves (on the coarse nodes of cells holding coarse
        particles, complete over ranks) and its inner slaves (27-node shapes), and add
        their mass and momentum to the masters."""
        occupied = self.occupied_nodes(grids.coarse, kinds)
        grids.coarse.slave_ties = []
        for w in grids.windows:
            w.ties = self.find_ties(w, grids.coarse, occupied)
            w.slave_ties = [w.ties]
            w.inner = self.find_inner_ties(w, grids.coarse)
            grids.coarse.slave_ties.append(w.inner)
            if grids.coarse.exact:          # after the shared-plane sums (before_reflect)
                sort_by_slave(w.ties)
                continue
            tied.slaves_to_masters(w.ties, w.nodal, grids.coarse.nodal)
            tied.slaves_to_masters(w.inner, grids.coarse.nodal, w.nodal)
        mark_tied_slaves(grids)

    def before_reflect(self, grids, what):
        """With layer-ordered sums: the slaves' ``what`` ("nodal" or "force") to their
        masters, now that the shared-plane sums are complete."""
        if grids.coarse.exact:
            self.add_slaves_in_rank_order(grids, what)

    def add_slaves_in_rank_order(self, grids, name):
        """Every window's tied slaves of the nodal array ``name`` added to their masters
        as one rank adds them (see the class), then the inner slaves to their window
        nodes."""
        coarse = grids.coarse
        target, b = getattr(coarse, name), coarse.block
        lower = lower_shared_rows(b, self.world.rank)
        rest = np.array([lower[1], b.n_nodes], np.int64)

        def add(master_rows):
            for w in grids.windows:
                tied.slaves_to_masters_in_rows(w.ties, getattr(w, name), target,
                                               np.array(w.owned_rows, np.int64), master_rows)
        add(rest)
        continue_shared_planes(self.world, b.shared_planes, b.as_planes(target),
                               lambda: add(np.array(lower, np.int64)))
        for w in grids.windows:
            tied.slaves_to_masters(w.inner, target, getattr(w, name))
            if w.level.halo:
                self.share_inner_terms(w, getattr(w, name))

    def share_inner_terms(self, window, array):
        """Give the inner slaves' terms to every rank holding their window nodes: a rank
        may hold a window node on a shared plane without the coarse node (a coarse node
        that only the rank below reaches, through the shapes' halo), and then takes the
        copy of the neighbour that added the term."""
        b = window.block
        marked = window.work.empty("inner_marked", b.n_nodes, 1, np.int8)[:, 0]
        marked.fill(0)
        marked[window.inner.masters[:window.inner.count, 0]] = 1
        flat = array.reshape(b.n_nodes, -1)
        take_marked_planes(self.world, b.shared_planes, b.as_planes(flat), b.as_planes(marked))

    def occupied_nodes(self, coarse, kinds):
        b = coarse.block
        if len(self.occupied) < b.n_nodes:
            self.occupied = np.empty(max(b.n_nodes, 1024) * 5 // 4, np.int64)
        occupied = self.occupied[:b.n_nodes]
        occupied.fill(0)
        for kind in kinds:
            kind.mark_occupied(coarse, occupied)
        or_shared_planes(self.world, b.shared_planes, b.as_planes(occupied))
        return occupied

    def find_ties(self, window, coarse, occupied):
        face_lo, face_hi = window.level.window_faces()
        faces = window.block.n_nodes - interior_nodes(window.block, face_lo, face_hi)
        slaves, masters, weights = self.buffers.get(window.index, (np.zeros(0, np.int64),) * 3)
        if len(slaves) < faces:
            slaves = np.empty(faces, np.int64)
            masters = np.empty((faces, 8), np.int64)
            weights = np.empty((faces, 8))
            self.buffers[window.index] = slaves, masters, weights
        ties = TieSet(slaves, masters, weights, 0)
        count = tied.find_ties(window.nodes, face_lo, face_hi, window.level.ratio,
                               coarse.nodes, occupied, ties)
        return ties._replace(count=count)

    def find_inner_ties(self, window, coarse):
        """The coarse nodes on the first layer inside the window's interface faces (those
        not on the grid box), tied to the window nodes at the same place; none with the
        hats, which never reach them."""
        win, n_cells = window.level.window, window.level.n_cells // window.level.ratio
        interface_lo, interface_hi = win.lo > 0, win.hi < n_cells
        inner_lo, inner_hi = win.lo + interface_lo, win.hi - interface_hi
        shell_lo = np.where(interface_lo, win.lo + 1, -1)
        shell_hi = np.where(interface_hi, win.hi - 1, -1)
        size = int(np.prod(np.maximum(inner_hi - inner_lo + 1, 0))) if window.level.halo else 0
        ties = self.inner_buffers.get(window.index)
        if ties is None or len(ties.slaves) < size:
            ties = TieSet(np.empty(size, np.int64), np.empty((size, 8), np.int64),
                          np.empty((size, 8)), 0)
            self.inner_buffers[window.index] = ties
        if not size:
            return ties._replace(count=0)
        count = tied.find_inner_ties(coarse.nodes, window.nodes, inner_lo, inner_hi,
                                     shell_lo, shell_hi, window.level.ratio, ties)
        return ties._replace(count=count)

    def after_velocities(self, grids):
        for w in grids.windows:
            tied.masters_to_slaves(w.ties, grids.coarse.gvel, w.gvel)
            tied.masters_to_slaves(w.inner, w.gvel, grids.coarse.gvel)

    def after_forces(self, grids):
        if grids.coarse.exact:              # after the shared-plane sums (before_reflect)
            return
        for w in grids.windows:
            tied.slaves_to_masters(w.ties, w.force, grids.coarse.force)
            tied.slaves_to_masters(w.inner, grids.coarse.force, w.force)

    def after_integrate(self, grids, dt):
        for w in grids.windows:
            tied.masters_to_slaves(w.ties, grids.coarse.gnew, w.gnew)
            tied.masters_to_slaves(w.inner, w.gnew, grids.coarse.gnew)


def sort_by_slave(ties):
    """Order a TieSet's rows by slave row in place (the slab axis slowest): the order
    in which the ranks that own the slaves' planes add them, lowest rank first."""
    n = ties.count
    order = np.argsort(ties.slaves[:n], kind="stable")
    for column in (ties.slaves, ties.masters, ties.weights):
        column[:n] = column[:n][order]


def lower_shared_rows(block, rank):
    """The rows [first, stop) of ``block``'s planes shared with the rank below ((0, 0)
    where there are none)."""
    per_plane = int(block.strides[block.slab_axis])
    for neighbour, span in block.shared_planes:
        if neighbour < rank:
            return span[0] * per_plane, span[1] * per_plane
    return 0, 0


def mark_tied_slaves(grids):
    """Every level's ``tied`` mask of this step's slaves, which the planes of symmetry
    leave alone (``LevelState.reflect``); only the 27-node shapes reach beyond a face."""
    for s in grids:
        if not len(s.mirror):
            continue
        s.tied = s.work.empty("tied", s.block.n_nodes, 1, np.int8)[:, 0]
        s.tied.fill(0)
        for ties in s.slave_ties:
            tied.mark_slaves(ties, s.tied)


def interior_nodes(block, face_lo, face_hi):
    """How many nodes of ``block`` lie strictly inside the window faces."""
    first = np.maximum(block.lo, face_lo + 1)
    last = np.minimum(block.lo + block.shape - 1, face_hi - 1)
    return int(np.prod(np.maximum(last - first + 1, 0)))


def kept_copy(kept, array):
    """``array`` copied into ``kept`` when the shapes agree (no allocation in the time
    loop while the counts stay), else a fresh copy: for start-of-step positions."""
    if kept is None or kept.shape != array.shape:
        return array.copy()
    np.copyto(kept, array)
    return kept
