"""The grids of one step on one rank: the coarse grid and the refined windows, each with
its node block and nodal arrays, and the tied interface between them (seed 000 Sec. 3.1).

The ties are linear in the nodal values, so each rank adds its own (partial) slave
values to the master nodes *before* the shared planes are summed: a slave on a slab plane
is then counted once on each rank with its share, a master on a slab plane gets every
rank's share through the sum, and no value is counted twice. Slave velocities and
accelerations are interpolated *after* the sums, from complete master values that every
rank holding the slave has alike.
"""
import numpy as np

from ..comm import sum_shared_planes
from ..comm.exchange import or_shared_planes
from ..kernels import mpm, tied
from .contact import ContactFields
from .workspace import Workspace


class Ties:
    """The tied slaves of one window block: ``slaves`` (local window nodes), ``masters``
    (local coarse nodes, (n, 8), -1: none) and ``weights`` (n, 8); ``count`` rows used."""

    def __init__(self):
        self.slaves = np.zeros(0, np.int64)
        self.masters = np.zeros((0, 8), np.int64)
        self.weights = np.zeros((0, 8))
        self.count = 0

    def find(self, level, block, coarse_block, occupied):
        shape = block.shape
        faces = 2 * (shape[0] * shape[1] + shape[1] * shape[2] + shape[0] * shape[2])
        if len(self.slaves) < faces:
            self.slaves = np.empty(faces, np.int64)
            self.masters = np.empty((faces, 8), np.int64)
            self.weights = np.empty((faces, 8))
        face_lo, face_hi = level.window_faces()
        self.count = tied.find_ties(block.shape, block.lo, block.strides, face_lo, face_hi,
                                    level.ratio, coarse_block.shape, coarse_block.lo,
                                    coarse_block.strides, occupied, self.slaves,
                                    self.masters, self.weights)

    def to_masters(self, fine, coarse):
        tied.slaves_to_masters(self.slaves, self.masters, self.weights, self.count, fine,
                               coarse)

    def from_masters(self, coarse, fine):
        tied.masters_to_slaves(self.slaves, self.masters, self.weights, self.count, coarse,
                               fine)


class LevelState:
    """One grid of the hierarchy on this rank (``index`` 0: the coarse grid; k > 0:
    window k - 1) and its nodal arrays of the current step (see ``pmpm.kernels.mpm``)."""

    def __init__(self, index, level, rules, world, m_tiny):
        self.index, self.level = index, level
        self.work = Workspace()
        self.contact = ContactFields(rules, world, self.work, m_tiny)
        self.ties = Ties() if level.is_window else None
        self.block = None

    def build_block(self, slabs, rank, cell_range):
        self.block = self.level.block(slabs, rank, *cell_range)


class Hierarchy:
    """The levels of one rank and the phases that couple them."""

    def __init__(self, grid_levels, rules, world, m_tiny):
        self.world = world
        self.states = [LevelState(i, level, rules, world, m_tiny)
                       for i, level in enumerate(grid_levels)]
        self.coarse = self.states[0]
        self.windows = self.states[1:]
        self.occupied = np.zeros(0, np.int64)

    def __iter__(self):
        return iter(self.states)

    def sum_shared(self, name):
        for state in self.states:
            b = state.block
            sum_shared_planes(self.world, b.shared_planes, b.as_planes(getattr(state, name)))

    def tie_windows(self, x, level_of):
        """Find every window's tied slaves (on the coarse nodes of cells holding coarse
        particles, complete over ranks) and add their mass and momentum to the masters."""
        if not self.windows:
            return
        c = self.coarse
        b = c.block
        if len(self.occupied) < b.n_nodes:
            self.occupied = np.empty(max(b.n_nodes, 1024) * 5 // 4, np.int64)
        occupied = self.occupied[:b.n_nodes]
        occupied.fill(0)
        tied.mark_occupied(x, level_of, c.level.origin, c.level.inv_h, b.lo, b.strides,
                           occupied)
        or_shared_planes(self.world, b.shared_planes, b.as_planes(occupied))
        for w in self.windows:
            w.ties.find(w.level, w.block, b, occupied)
            w.ties.to_masters(w.nodal, c.nodal)

    def slave_velocities(self):
        for w in self.windows:
            w.ties.from_masters(self.coarse.gvel, w.gvel)

    def slave_forces_to_masters(self):
        for w in self.windows:
            w.ties.to_masters(w.force, self.coarse.force)

    def slave_motion(self):
        for w in self.windows:
            w.ties.from_masters(self.coarse.gnew, w.gnew)

    def n_nodes(self):
        return sum(s.block.n_nodes for s in self.states)


def level_spans(x, level_of, grid, levels):
    """Per level, (-lowest, highest) level cell of its particles inside the grid box:
    float64 (n_levels * 6,), for one MAX reduction over ranks."""
    ratios = np.array([lv.ratio for lv in levels], np.int64)
    inv_hs = np.array([lv.inv_h for lv in levels])
    span = np.empty(6 * len(levels))
    mpm.level_spans(x, level_of, grid.origin, 1.0 / grid.h, grid.n_cells, ratios, inv_hs,
                    span)
    return span
