"""One explicit update-stress-first step (DESIGN.md "One time step"), phase by phase."""
import numpy as np

from ..comm import sum_shared_planes, migrate
from ..comm.slabs import balanced_bounds, Slabs
from ..grid import LocalBlock
from ..kernels import mpm
from .contact import ContactFields, ContactRules
from .errors import SolverError


class Workspace:
    """Nodal arrays reused from step to step (grown, never shrunk)."""

    def __init__(self):
        self._buffers = {}

    def zeros(self, name, rows, width):
        view = self.empty(name, rows, width)
        view.fill(0.0)
        return view

    def empty(self, name, rows, width):
        """Uninitialised rows, for arrays a kernel overwrites entirely."""
        buf = self._buffers.get(name)
        if buf is None or buf.shape[0] < rows:
            buf = np.empty((max(rows, 1024) * 5 // 4, width))
            self._buffers[name] = buf
        return buf[:rows]


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
    """

    def __init__(self, world, grid, slabs, particles, bodies, gravity, m_tiny, contact=None):
        self.world, self.grid, self.slabs = world, grid, slabs
        self.particles, self.bodies = particles, bodies
        self.gravity = np.asarray(gravity, dtype=np.float64)
        self.m_tiny = m_tiny
        self.work = Workspace()
        self.load_vec = np.zeros((1, 3))
        self.fastest = 0.0
        self.lost = 0
        self.block = None
        self.fault = None
        self.cell_range = self.global_cell_range()
        self.rules = ContactRules(contact or {}, bodies)
        self.contact = ContactFields(self.rules, world, self.work, m_tiny)

    # -- the step ---------------------------------------------------------------
    def step(self, dt):
        self.fault = None
        self.build_block()
        self.map_particles_to_grid()
        self.nodal_velocities_with_boundaries()
        self.update_stress_and_nodal_forces(dt)
        self.integrate_nodal_momentum(dt)
        self.update_particles(dt)
        self.migrate_and_check()

    def build_block(self):
        lo, hi = self.cell_range
        self.block = LocalBlock.for_rank(self.slabs, self.world.rank, lo, hi)

    def map_particles_to_grid(self):
        p, b = self.particles, self.block
        self.nodal = self.work.zeros("nodal", b.n_nodes, mpm.NODAL_COMPONENTS)
        mpm.particles_to_grid(p.x, p.v, p.mass, p.body, self.bodies.rigid, self.grid.origin,
                              1.0 / self.grid.h, b.lo, b.strides, self.nodal)
        sum_shared_planes(self.world, b.shared_planes, b.as_planes(self.nodal))
        if self.rules.active:
            self.contact.map_particles(p, self.grid, b, len(self.bodies.names))

    def nodal_velocities_with_boundaries(self):
        b = self.block
        self.gvel = self.work.empty("gvel", b.n_nodes, 3)
        mpm.nodal_velocities(self.nodal, b.shape, b.lo, b.strides, self.grid.n_cells,
                             self.grid.boundary, self.m_tiny, self.gvel)
        if self.rules.active:
            self.contact.start_velocities(self.gvel, self.bodies, self.grid, b)

    def update_stress_and_nodal_forces(self, dt):
        p, b, g = self.particles, self.block, self.grid
        self.force = self.work.zeros("force", b.n_nodes, 3)
        self.fastest, bad = mpm.stress_and_forces(
            p.x, p.v, p.mass, p.rho, p.stress, p.F, p.eps_p, p.e_int, p.temp, p.q, p.body,
            p.load, p.load_scale, self.bodies.codes, self.bodies.params, self.bodies.rigid,
            dt, g.h, self.gravity, self.load_vec, g.origin, 1.0 / g.h, b.lo, b.strides,
            self.gvel, self.force, *self.contact_arrays("cvel", "cforce"))
        self.note_fault(bad, "constitutive update failed (NaN, non-convergence or "
                             "non-positive density)")
        sum_shared_planes(self.world, b.shared_planes, b.as_planes(self.force))

    def integrate_nodal_momentum(self, dt):
        b = self.block
        self.gnew = self.work.empty("gnew", b.n_nodes, 6)
        mpm.integrate_nodes(self.nodal, self.force, self.gvel, dt, b.shape, b.lo, b.strides,
                            self.grid.n_cells, self.grid.boundary, self.m_tiny, self.gnew)
        if self.rules.active:
            self.contact.end_velocities(self.gnew, self.bodies, dt, self.grid, b)

    def update_particles(self, dt):
        p, b, g = self.particles, self.block, self.grid
        bad = mpm.grid_to_particles(p.x, p.v, p.body, self.bodies.rigid, dt, g.origin,
                                    1.0 / g.h, b.lo, b.strides, self.gnew,
                                    *self.contact_arrays("cnew"))
        self.note_fault(bad, "position is not finite")

    def migrate_and_check(self):
        """Drop particles that left the grid box, send the rest to their slab owners, and
        agree on the next step's cell range and wave speed: one MAX reduction, plus an
        Alltoallv only when some particle changes rank."""
        p, g, slabs = self.particles, self.grid, self.slabs
        owner = np.empty(p.n, np.int64)
        local = np.empty(10)
        outside = mpm.classify_particles(p.x, g.origin, 1.0 / g.h, g.n_cells, slabs.axis,
                                         slabs.bounds, owner, local[:6])
        local[6] = self.fastest
        local[7] = float(outside)
        local[8] = float(np.count_nonzero((owner != self.world.rank) & (owner >= 0)))
        local[9] = 1.0 if self.fault else 0.0
        glob = self.world.max(local)
        if glob[9] > 0:
            raise SolverError(self.world.first_message(self.fault))
        self.fastest = glob[6]
        self.cell_range = _cell_range(glob[:6])
        if glob[7] > 0:
            self.lost += self.world.sum(outside)
            p.take(owner >= 0)
            owner = owner[owner >= 0]
        if glob[8] > 0:
            migrate(self.world, owner, p.columns(), check=False, replace=p.replace_column)

    # -- helpers ----------------------------------------------------------------
    def contact_arrays(self, *names):
        """(contact on?, slot_of, the named per-slot arrays) for the particle kernels;
        empty stand-ins when contact is off."""
        if not self.rules.active:
            return (False, self.contact.slot_of) + (self.contact.empty,) * len(names)
        return (True, self.contact.slot_of) + tuple(getattr(self.contact, n) for n in names)

    def send_to_owners(self, slabs):
        p = self.particles
        cells = self.grid.cells_of(p.x)[:, slabs.axis] if p.n else np.zeros(0, np.int64)
        owners = slabs.owner_of_cells(cells).astype(np.int64)
        migrate(self.world, owners, p.columns(), replace=p.replace_column)

    def global_cell_range(self):
        """Lowest and highest coarse cell holding a particle on any rank."""
        p = self.particles
        local = np.full(6, -(2.0 ** 62))
        if p.n:
            cells = self.grid.cells_of(p.x)
            local[:3], local[3:] = -cells.min(axis=0), cells.max(axis=0)
        return _cell_range(self.world.max(local))

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
        self.cell_range = self.global_cell_range()
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


def _cell_range(span):
    """(lowest, highest) cell from a reduced span (-lowest, highest); empty if none."""
    lo, hi = (-span[:3]).astype(np.int64), span[3:6].astype(np.int64)
    if np.any(hi < lo):
        return np.zeros(3, np.int64), -np.ones(3, np.int64)
    return lo, hi
