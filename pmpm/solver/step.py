"""One explicit update-stress-first step (DESIGN.md "One time step"), phase by phase,
over the coarse grid and any refined windows tied to it (seed 000 Sec. 4)."""
import numpy as np

from ..comm import migrate
from ..comm.slabs import balanced_bounds, Slabs
from ..grid import Level, window_bounds
from ..kernels import mpm, tied
from .contact import ContactRules
from .errors import SolverError
from .levels import Hierarchy, level_spans
from .refine import Refiner
from .workspace import Workspace

__all__ = ["Stepper", "Workspace"]


class Stepper:
    """Advances the particles of one rank by one time step, in step with the other ranks.

    Parameters
    ----------
    world : comm.World
    grid : grid.CoarseGrid
    slabs : comm.Slabs
    particles : particles.Particles
    bodies : solver.bodies.BodyTable
    gravity : (3,) array
    m_tiny : float   nodal mass below which a node counts as empty
    contact : dict   the case's ``contact`` section
    windows : list of grid.Window   refined windows (seed 000 Sec. 3)
    id_base : int    above every particle id at the start (split particles' ids)
    scheme : str     "usf" (update stress first) or "musl" (modified update stress last)
    """

    def __init__(self, world, grid, slabs, particles, bodies, gravity, m_tiny, contact=None,
                 windows=(), id_base=0, scheme="usf"):
        self.world, self.grid, self.slabs = world, grid, slabs
        self.particles, self.bodies = particles, bodies
        self.gravity = np.asarray(gravity, dtype=np.float64)
        self.m_tiny = m_tiny
        self.load_vec = np.zeros((1, 3))
        self.fastest = 0.0
        self.lost = 0
        self.fault = None
        self.scheme = scheme
        self.work = Workspace()         # the MUSL position copies
        self.rules = ContactRules(contact or {}, bodies)
        self.windows = list(windows)
        self.levels = [Level(grid)] + [Level(grid, w) for w in self.windows]
        self.grids = Hierarchy(self.levels, self.rules, world, m_tiny)
        self.refiner = Refiner(self, id_base)
        self.level_of = np.zeros(0, np.int32)
        self.cell_ranges = self.global_cell_ranges()

    # -- the step ---------------------------------------------------------------
    def step(self, dt):
        self.fault = None
        self.assign_levels()
        self.build_blocks()
        self.map_particles_to_grid()
        self.nodal_velocities_with_boundaries()
        if self.scheme == "musl":
            self.nodal_forces()
            self.integrate_nodal_momentum(dt)
            self.update_particles_then_stresses(dt)
        else:
            self.update_stress_and_nodal_forces(dt)
            self.integrate_nodal_momentum(dt)
            self.update_particles(dt)
        self.refiner.move_windows_and_split()
        self.migrate_and_check()

    def assign_levels(self):
        """The grid each particle maps to: the window holding it, else the coarse grid."""
        p = self.particles
        if len(self.level_of) != p.n:
            self.level_of = np.zeros(p.n, np.int32)
        if self.windows:
            lo, hi = window_bounds(self.windows)
            tied.particle_levels(p.x, self.grid.origin, 1.0 / self.grid.h, lo, hi,
                                 self.level_of)
        return self.level_of

    def build_blocks(self):
        for state, cell_range in zip(self.grids, self.cell_ranges):
            state.build_block(self.slabs, self.world.rank, cell_range)

    def map_particles_to_grid(self):
        """Particle-to-grid on every level (Eqs. 12-13), the slaves' mass and momentum to
        their masters (Eqs. 17, 20), then the sums over shared slab planes."""
        p, nb = self.particles, len(self.bodies.names)
        for s in self.grids:
            b, lv = s.block, s.level
            s.nodal = s.work.zeros("nodal", b.n_nodes, mpm.NODAL_COMPONENTS)
            mpm.particles_to_grid(p.x, p.v, p.mass, p.body, self.bodies.rigid, lv.origin,
                                  lv.inv_h, b.lo, b.strides, s.nodal, self.level_of, s.index)
        self.grids.tie_windows(p.x, self.level_of)
        self.grids.sum_shared("nodal")
        if self.rules.active:
            for s in self.grids:
                s.contact.map_particles(p, s.level, s.block, nb, self.level_of, s.index,
                                        s.ties)

    def nodal_velocities_with_boundaries(self):
        """Nodal velocities with the boundary conditions; slaves from masters (Eq. 22);
        method 2's contact correction (seed 001 Eqs. 23-25)."""
        for s in self.grids:
            b, lv = s.block, s.level
            s.gvel = s.work.empty("gvel", b.n_nodes, 3)
            mpm.nodal_velocities(s.nodal, b.shape, b.lo, b.strides, lv.n_cells, lv.boundary,
                                 self.m_tiny, s.gvel)
        self.grids.slave_velocities()
        if self.rules.active:
            for s in self.grids:
                s.contact.start_velocities(s.gvel, self.bodies, s.level, s.block)

    def update_stress_and_nodal_forces(self, dt):
        """Stress update and nodal forces on every level; slave forces to their masters
        (Eq. 18); the sums over shared slab planes. The wave speed for the next step is
        kept as the speed that gives the same Courant number on the coarse grid."""
        p = self.particles
        self.fastest = 0.0
        for s in self.grids:
            b, lv = s.block, s.level
            s.force = s.work.zeros("force", b.n_nodes, 3)
            fastest, bad = mpm.stress_and_forces(
                p.x, p.v, p.mass, p.rho, p.stress, p.F, p.eps_p, p.e_int, p.temp, p.q,
                p.body, p.load, p.load_scale, self.bodies.codes, self.bodies.params,
                self.bodies.rigid, dt, lv.h, self.gravity, self.load_vec, lv.origin,
                lv.inv_h, b.lo, b.strides, s.gvel, s.force,
                *self.contact_arrays(s, "cvel", "cforce"), self.level_of, s.index)
            self.fastest = max(self.fastest, fastest * lv.ratio)
            self.note_fault(bad, "constitutive update failed (NaN, non-convergence or "
                                 "non-positive density)")
        self.grids.slave_forces_to_masters()
        self.grids.sum_shared("force")

    def nodal_forces(self):
        """MUSL: nodal forces from the stresses of the start of the step (Eqs. 31-32),
        slave forces to their masters, the sums over shared slab planes."""
        p = self.particles
        for s in self.grids:
            b, lv = s.block, s.level
            s.force = s.work.zeros("force", b.n_nodes, 3)
            mpm.scatter_forces(p.x, p.mass, p.rho, p.stress, p.q, p.body, p.load,
                               p.load_scale, self.bodies.rigid, self.gravity, self.load_vec,
                               lv.origin, lv.inv_h, b.lo, b.strides, s.force,
                               *self.contact_arrays(s, "cforce"), self.level_of, s.index)
        self.grids.slave_forces_to_masters()
        self.grids.sum_shared("force")

    def update_particles_then_stresses(self, dt):
        """MUSL: move the particles and update their velocities as USF does, map the new
        velocities back to the grid from the start-of-step positions (boundary
        conditions, and method 2's contact correction, applied again), and update the
        stresses from those nodal velocities."""
        p = self.particles
        start = self.work_copy("x_start", p.x)
        self.update_particles(dt)
        moved = self.work_copy("x_moved", p.x)
        p.x[:] = start
        self.map_particles_to_grid()
        self.nodal_velocities_with_boundaries()
        self.fastest = 0.0
        for s in self.grids:
            b, lv = s.block, s.level
            fastest, bad = mpm.update_stresses(
                p.x, p.v, p.rho, p.stress, p.F, p.eps_p, p.e_int, p.temp, p.q, p.body,
                self.bodies.codes, self.bodies.params, self.bodies.rigid, dt, lv.h,
                lv.origin, lv.inv_h, b.lo, b.strides, s.gvel,
                *self.contact_arrays(s, "cvel"), self.level_of, s.index)
            self.fastest = max(self.fastest, fastest * lv.ratio)
            self.note_fault(bad, "constitutive update failed (NaN, non-convergence or "
                                 "non-positive density)")
        p.x[:] = moved

    def integrate_nodal_momentum(self, dt):
        """Leap-frog on the nodes of every level (Eq. 14); contact forces (seed 001 Eqs.
        11-22); slaves follow their masters (Eqs. 23-24)."""
        for s in self.grids:
            b, lv = s.block, s.level
            s.gnew = s.work.empty("gnew", b.n_nodes, 6)
            mpm.integrate_nodes(s.nodal, s.force, s.gvel, dt, b.shape, b.lo, b.strides,
                                lv.n_cells, lv.boundary, self.m_tiny, s.gnew)
            if self.rules.active:
                s.contact.end_velocities(s.gvel, s.gnew, self.bodies, dt, lv, b)
        self.grids.slave_motion()

    def update_particles(self, dt):
        p = self.particles
        for s in self.grids:
            b, lv = s.block, s.level
            bad = mpm.grid_to_particles(p.x, p.v, p.body, self.bodies.rigid, dt, lv.origin,
                                        lv.inv_h, b.lo, b.strides, s.gnew,
                                        *self.contact_arrays(s, "cnew"), self.level_of,
                                        s.index)
            self.note_fault(bad, "position is not finite")

    def migrate_and_check(self):
        """Drop particles that left the grid box, send the rest to their slab owners, and
        agree on the next step's cell ranges and wave speed: one MAX reduction, plus an
        Alltoallv only when some particle changes rank."""
        p, g, slabs = self.particles, self.grid, self.slabs
        owner = np.empty(p.n, np.int64)
        outside = mpm.classify_particles(p.x, g.origin, 1.0 / g.h, g.n_cells, slabs.axis,
                                         slabs.bounds, owner)
        spans = level_spans(p.x, self.assign_levels(), g, self.levels)
        local = np.concatenate([[self.fastest, float(outside),
                                 float(np.count_nonzero((owner != self.world.rank)
                                                        & (owner >= 0))),
                                 1.0 if self.fault else 0.0], spans])
        glob = self.world.max(local)
        if glob[3] > 0:
            raise SolverError(self.world.first_message(self.fault))
        self.fastest = glob[0]
        self.cell_ranges = _cell_ranges(glob[4:])
        if glob[1] > 0:
            self.lost += self.world.sum(outside)
            p.take(owner >= 0)
            owner = owner[owner >= 0]
        if glob[2] > 0:
            migrate(self.world, owner, p.columns(), check=False, replace=p.replace_column)

    # -- helpers ----------------------------------------------------------------
    def contact_arrays(self, state, *names):
        """(contact on?, slot_of, the named per-slot arrays) for the particle kernels;
        empty stand-ins when contact is off."""
        c = state.contact
        if not self.rules.active:
            return (False, c.slot_of) + (c.empty,) * len(names)
        return (True, c.slot_of) + tuple(getattr(c, n) for n in names)

    def work_copy(self, name, array):
        """A copy of the (n, 3) ``array`` in the reused buffer ``name``."""
        copy = self.work.empty(name, len(array), 3)
        copy[:] = array
        return copy

    def send_to_owners(self, slabs):
        p = self.particles
        cells = self.grid.cells_of(p.x)[:, slabs.axis] if p.n else np.zeros(0, np.int64)
        owners = slabs.owner_of_cells(cells).astype(np.int64)
        migrate(self.world, owners, p.columns(), replace=p.replace_column)

    def global_cell_ranges(self):
        """Per level, the lowest and highest level cell holding a particle on any rank."""
        spans = level_spans(self.particles.x, self.assign_levels(), self.grid, self.levels)
        return _cell_ranges(self.world.max(spans))

    def note_fault(self, bad, what):
        """Remember this rank's first bad particle of the step; the end-of-step reduction
        tells every rank, and every rank then raises the same error (no extra collective
        per phase)."""
        if bad >= 0 and self.fault is None:
            p = self.particles
            self.fault = (f"particle id {int(p.id[bad])} of body "
                          f"'{self.bodies.names[int(p.body[bad])]}': {what}")

    def rebalance(self, threshold):
        """Move slab planes when max/mean particle count - 1 exceeds ``threshold``.
        Returns the imbalance before any move, and whether the slabs moved."""
        counts = self.slab_axis_histogram()
        imbalance = self.slabs.imbalance(counts)
        if self.world.size == 1 or imbalance <= threshold:
            return imbalance, False
        new = Slabs(self.slabs.axis, balanced_bounds(counts, self.world.size))
        if new == self.slabs:
            return imbalance, False
        self.slabs = new
        self.send_to_owners(new)
        self.cell_ranges = self.global_cell_ranges()
        return imbalance, True

    def slab_axis_histogram(self):
        a = self.slabs.axis
        cells = self.grid.cells_of(self.particles.x)[:, a]
        local = np.bincount(cells, minlength=int(self.grid.n_cells[a])).astype(np.int64)
        return self.world.sum(local)

    def sort_by_cell(self):
        """Order particles by coarse cell so scatter and gather walk memory in order."""
        p = self.particles
        keys = mpm.cell_keys(p.x, self.grid.origin, 1.0 / self.grid.h, self.grid.n_cells)
        p.take(np.argsort(keys, kind="stable"))


def _cell_ranges(spans):
    """Per level, (lowest, highest) cell from reduced spans (-lowest, highest) * levels;
    an empty range (highest < lowest) where a level has no particle."""
    ranges = []
    for start in range(0, len(spans), 6):
        span = spans[start:start + 6]
        lo, hi = (-span[:3]).astype(np.int64), span[3:6].astype(np.int64)
        if np.any(hi < lo):
            lo, hi = np.zeros(3, np.int64), -np.ones(3, np.int64)
        ranges.append((lo, hi))
    return ranges
