"""Who holds what: the slabs of the coarse grid each rank owns, the cells of every grid
level that hold points (the extent of each rank's node blocks), migration of points to
their slab's rank, and rebalancing of the slab planes (DESIGN.md "Parallel model")."""
import numpy as np

from ..comm import migrate_store
from ..comm.slabs import Slabs, balanced_bounds
from ..kernels import exact_sum
from ..kernels.shape import HALO
from .errors import SolverError
from .levels import cell_ranges
from .observe import exact_totals
from .workspace import Workspace


class Decomposition:
    """The slab decomposition of one run, over every body kind's points.

    Parameters
    ----------
    world : comm.World
    grid : grid.CoarseGrid
    slabs : comm.Slabs
    grids : solver.levels.Hierarchy   (its levels give the per-level cell ranges)
    windows : list of grid.Window
    n_bodies : int
        Number of bodies, for the per-body count and mass of the points that left.
    exact : bool
        ``grid.exact_sums``: the lost mass summed exactly over the ranks (it decides
        the ``grid.lost_mass_fraction`` fault, so it must not depend on the rank count).
    """

    def __init__(self, world, grid, slabs, grids, windows, n_bodies=1, exact=False):
        self.world, self.grid, self.slabs = world, grid, slabs
        self.grids, self.windows = grids, windows
        #: the narrowest slab (cells): 3 for the 27-node shapes (comm.slabs.balanced_bounds)
        self.min_width = slab_min_width(grids.coarse.shape)
        self.cell_ranges = []
        #: other points the blocks must cover (FE nodes on the grid): objects with
        #: ``spans(grids, grid)``
        self.span_sources = []
        self.lost = 0
        self.lost_count = np.zeros(n_bodies)   # per body, over all ranks
        self.lost_mass = np.zeros(n_bodies)
        self.exact = bool(exact)
        self.work = Workspace()     # per kind, the owners' array, reused step to step

    def assign_levels(self, kinds):
        for kind in kinds:
            kind.assign_levels(self.grid, self.windows)

    def spans(self, kinds):
        """Per level, (-lowest, highest) cell of every kind's points (max over kinds)."""
        self.assign_levels(kinds)
        return self.with_sources([self.grids.spans(self.grid, k.particles.x, k.level_of)
                                  for k in kinds])

    def with_sources(self, spans):
        """The kinds' ``spans`` and those of the other points (span_sources), reduced."""
        spans = spans + [source.spans(self.grids, self.grid) for source in self.span_sources]
        return np.maximum.reduce(spans)

    def update_cell_ranges(self, kinds):
        self.cell_ranges = cell_ranges(self.world.max(self.spans(kinds)))

    def build_blocks(self):
        self.grids.build_blocks(self.slabs, self.world.rank, self.cell_ranges)

    def finish_step(self, kinds, fastest, fault):
        """Drop points that left the grid box, send the rest to their slab owners, and
        agree on the next step's cell ranges and wave speed: one MAX reduction, plus an
        Alltoallv only when some point changes rank. Raises the first rank's ``fault``
        on every rank. Returns the fastest speed over all ranks."""
        owners = [self.owners_of(i, k.n) for i, k in enumerate(kinds)]
        self.assign_levels(kinds)
        ends = [k.owners_and_spans(self.grids, self.grid, self.slabs, self.world.rank, o)
                for k, o in zip(kinds, owners)]
        outside = [e[0] for e in ends]
        moving = [e[1] for e in ends]
        spans = self.with_sources([e[2] for e in ends])
        head = [fastest, 1.0 if fault else 0.0]
        local = np.concatenate([head, outside, moving, spans]).astype(np.float64)
        glob = self.world.max(local)
        if glob[1] > 0:
            raise SolverError(self.world.first_message(fault))
        n = len(kinds)
        self.cell_ranges = cell_ranges(glob[2 + 2 * n:])
        for i, kind in enumerate(kinds):
            owner = owners[i]
            if glob[2 + i] > 0:
                self.lost += self.world.sum(outside[i])
                self.count_lost(kind.particles, owner < 0)
                kind.particles.take(owner >= 0)
                owner = owner[owner >= 0]
            if glob[2 + n + i] > 0:
                migrate_store(self.world, owner, kind.particles, check=False)
        return glob[0]

    def owners_of(self, i, n):
        """Room for the owner ranks of kind i's ``n`` points, kept from step to step: a
        fresh array each step was the step's one page-faulted allocation on the Taylor
        bar (1.35 MB at 0.38 mm, 330 faults a step)."""
        return self.work.empty(f"owners{i}", n, 1, np.int64)[:, 0]

    def count_lost(self, points, gone):
        """Add the count and mass, per body, of the ``gone`` points (collective; the
        mass exactly rounded with exact sums, so the same bits on any rank count)."""
        nb = len(self.lost_count)
        body, mass = points.body[gone], points.mass[gone]
        counts = self.world.sum(np.bincount(body, minlength=nb)[:nb].astype(np.float64))
        if self.exact:
            acc = exact_sum.zeros(nb)
            for b in np.unique(body[body < nb]):
                exact_sum.add_terms(acc, b, mass[body == b])
            lost = exact_totals(self.world, [acc])[0]
        else:
            # float64 on every rank: bincount of no points gives int64 even with
            # weights, and a SUM over ranks whose buffers differ in type is garbage
            lost = self.world.sum(np.bincount(body, mass, minlength=nb)[:nb]
                                  .astype(np.float64))
        self.lost_count += counts
        self.lost_mass += lost

    def send_to_owners(self, kinds):
        for kind in kinds:
            cells = kind.slab_cells(self.grid, self.slabs.axis) if kind.n else \
                np.zeros(0, np.int64)
            owners = self.slabs.owner_of_cells(cells).astype(np.int64)
            migrate_store(self.world, owners, kind.particles)

    def rebalance(self, threshold, kinds, counted=()):
        """Move slab planes when the weighted imbalance (:meth:`imbalance`) exceeds
        ``threshold`` (the ``counted`` kinds, FEM elements, count too but move
        themselves). Returns the imbalance before any move, and whether the slabs
        moved."""
        counts = self.slab_axis_histogram(list(kinds) + list(counted))
        imbalance = self.slabs.imbalance(counts)
        if self.world.size == 1 or imbalance <= threshold:
            return imbalance, False
        new = Slabs(self.slabs.axis, balanced_bounds(counts, self.world.size, self.min_width))
        if new == self.slabs:
            return imbalance, False
        self.slabs = new
        self.send_to_owners(kinds)
        self.update_cell_ranges(kinds)
        return imbalance, True

    def imbalance(self, kinds):
        """max/mean - 1 over the ranks of the work their slabs hold, each point counted
        with its kind's weight (solver.work_weights: particles 1, elements their cost in
        particle-steps) (collective)."""
        return self.slabs.imbalance(self.slab_axis_histogram(kinds))

    def slab_axis_histogram(self, kinds):
        """The points' weights summed per coarse cell layer along the slab axis, over
        all ranks (a kind's ``slab_weights()`` None: each point counts 1)."""
        a = self.slabs.axis
        n = int(self.grid.n_cells[a])
        local = np.zeros(n)
        for k in kinds:
            local += np.bincount(k.slab_cells(self.grid, a), k.slab_weights(), minlength=n)
        return self.world.sum(local)


def slab_min_width(shape):
    """The narrowest slab, in coarse cells, for a shape-function code: the particles of
    the two neighbours each reach HALO node layers into it, and no node may be reached
    from both sides (the sums over slab planes gather a node from its own two ranks)."""
    return 1 + 2 * HALO[shape]
