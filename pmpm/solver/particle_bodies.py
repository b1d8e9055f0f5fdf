"""The particle bodies of one rank as a body kind of the step: what particles do in each
phase (seed 000 Eqs. 12-16, seed 001 Eqs. 27-34), on each grid of the hierarchy.

A body kind answers the phases of :class:`pmpm.solver.step.Stepper`; a second kind
(finite-element bodies) answers the same calls with its own kernels.
"""
import numpy as np

from ..kernels import contact as kc
from ..kernels import mpm, tied
from ..kernels.observe import mass_moment_along, moment_along_exact
from ..kernels.records import BodyMaterials, ExternalLoads, PointState
from ..kernels.shape import GIMP
from ..grid import window_bounds
from ..particles.split import split
from .energy import load_power, load_power_terms
from .kinds import BodyKind
from .observe import body_stats, particle_energies, particle_energy_sums
from .workspace import Workspace


class ParticleBodies(BodyKind):
    """The particles this rank owns, with the per-body tables the kernels index.

    Parameters
    ----------
    particles : particles.Particles
    bodies : solver.bodies.BodyTable
    gravity : (3,) array
    pic : float   share of the PIC velocity in the particle velocity update (0: FLIP)
    transfer : str   ``flip`` (the FLIP/PIC blend of ``pic``) or ``apic`` (the affine
        transfer, pmpm.kernels.affine: the particles' ``affine`` column is scattered with
        the momentum and gathered with the velocity)
    """

    label = "particle"
    on_grid = follows_slabs = True

    def __init__(self, particles, bodies, gravity, pic=0.0, transfer="flip"):
        self.particles, self.bodies = particles, bodies
        self.pic = float(pic)
        self.apic = transfer == "apic"
        self.gravity = np.asarray(gravity, dtype=np.float64)
        self.load_vectors = np.zeros((1, 3))
        self.materials = BodyMaterials(bodies.codes, bodies.params, bodies.rigid)
        self.level_of = np.zeros(0, np.int32)
        self.work = Workspace()
        self.fault = None
        #: per grid level, the canonical order of the layer-ordered scatters and the id
        #: column it sorts (set by each mass scatter)
        self.orders = {}
        self.kept_identity = np.zeros(0, np.int64)
        self.windows = []           # the refined windows (seen by assign_levels)
        #: with windows, each particle's cell layer along the slab axis at the last mass
        #: scatter (a followed body's centroid: layer_moments)
        self.slab_layer = np.zeros(0, np.int64)
        self.exact = False          # layer-ordered sums (set by the simulation)

    # -- records --------------------------------------------------------------------
    def points(self):
        p = self.particles
        return PointState(p.x, p.v, p.mass, p.body, self.level_of)

    def loads(self):
        p = self.particles
        return ExternalLoads(self.gravity, self.load_vectors, p.load, p.load_scale)

    def affine(self):
        """The APIC matrices the transfer kernels read and write, or None under FLIP."""
        return self.particles.affine if self.apic else None

    @property
    def n(self):
        return self.particles.n

    # -- grid levels -------------------------------------------------------------------
    def assign_levels(self, grid, windows):
        """The grid each particle maps to: the window holding it, else the coarse grid."""
        p = self.particles
        self.windows = windows
        if len(self.level_of) != p.n:
            self.level_of = np.zeros(p.n, np.int32)
        if windows:
            lo, hi = window_bounds(windows)
            tied.particle_levels(p.x, grid.origin, 1.0 / grid.h, lo, hi, self.level_of)
        return self.level_of

    # -- phases ------------------------------------------------------------------------
    def scatter_mass_momentum(self, state):
        if state.exact:              # the points' positions of this scatter
            lv = state.level
            if state.index == 0 and self.windows:     # the layers that tell the ranks
                a = state.block.slab_axis
                self.slab_layer = np.floor((self.particles.x[:, a] - lv.origin[a])
                                           * lv.inv_h).astype(np.int64)
            order = self.canonical_order(lv.origin, lv.inv_h, lv.n_cells,
                                         state.block.slab_axis, state.index)
            self.orders[state.index] = (order, self.particles.id)
        mpm.particles_to_grid(self.points(), self.bodies.rigid, state.geometry, state.nodal,
                              state.index, self.affine(),
                              state.layer_sums("nodal", mpm.NODAL_COMPONENTS,
                                               self.order_on(state)))

    @property
    def order(self):
        """The canonical order on the coarse grid (its last mass scatter's)."""
        return self.orders.get(0, (NO_ORDER,))[0]

    def order_on(self, state):
        """The canonical order of the level ``state``'s layer-ordered scatters (that of
        its last mass scatter)."""
        return self.orders.get(state.index, (NO_ORDER,))[0]

    def canonical_order(self, origin, inv_h, n_cells, axis, index=0):
        """The particles of the grid level ``index`` (all of them without windows) by
        (cell of that level (cell size 1 / ``inv_h``) with the slab ``axis`` slowest,
        id): a rank's particles of a cell layer are then the one-rank order's, whatever
        migration appended, and a layer's particles are one run of it
        (``pmpm.kernels.layered``)."""
        p = self.particles
        keys = self.work.empty("keys", p.n, 1, np.int64)[:, 0]
        if not mpm.canonical_keys(p.x, p.id, origin, inv_h, n_cells, axis, keys):
            order = np.lexsort((p.id, mpm.slab_cell_keys(p.x, origin, inv_h, n_cells, axis)))
            return order if not self.windows else order[self.level_of[order] == index]
        last, of = self.orders.get(index, (NO_ORDER, None))
        if self.windows:
            fresh = np.flatnonzero(self.level_of == index)
            same = len(last) == len(fresh) and bool(np.all(self.level_of[last] == index))
        else:
            fresh, same = None, len(last) == p.n
        # the last step's order if still over the same columns (migration replaces them),
        # else the particles as they are, copied into a kept buffer that is not the last
        # order's (a fresh array each step was page-faulted in under the 128 KiB mmap
        # threshold: 1,000 faults a step on the steel ball)
        start = last if of is p.id and same else fresh
        order = self.order_buffer(index, last, p.n if start is None else len(start))
        if start is None:
            order[:] = self.identity(p.n)
        else:
            order[:] = start
        if mpm.sort_nearly_sorted(keys, order, 8 * len(order)):
            return order
        return order[np.argsort(keys[order], kind="stable")]

    def identity(self, n):
        """0, 1, ..., n - 1 (a view of an array kept and grown)."""
        if len(self.kept_identity) < n:
            self.kept_identity = np.arange(max(n, 1024) * 5 // 4, dtype=np.int64)
        return self.kept_identity[:n]

    def order_buffer(self, index, last, n):
        """Room for level ``index``'s next canonical order: one of two arrays kept for it,
        the one that does not hold ``last``."""
        for name in (f"order{index}a", f"order{index}b"):
            rows = self.work.empty(name, n, 1, np.int64)[:, 0]
            if not np.may_share_memory(rows, last):
                return rows
        raise AssertionError("both order buffers hold the last order")

    def mark_occupied(self, coarse, occupied):
        """The coarse nodes of cells holding coarse particles (the tied-interface search)."""
        g = coarse.geometry
        tied.mark_occupied(self.particles.x, self.level_of, g.origin, g.inv_h, g.lo,
                           g.strides, occupied)

    def mark_bodies(self, state, mask):
        kc.body_masks(self.points(), state.geometry, mask, state.index)

    def scatter_contact(self, state, slot_of, cnodal):
        layers = state.layer_sums("cnodal", cnodal.shape[1] * cnodal.shape[2],
                                  self.order_on(state),
                                  state.slot_starts)
        kc.contact_particles_to_grid(self.points(), state.geometry, slot_of, cnodal,
                                     state.index, self.affine(), layers)

    def scatter_extents(self, state, slot_of, cext):
        kc.contact_extents(self.points(), state.geometry, slot_of, cext, state.index)

    def scatter_volumes(self, state, slot_of, cvol):
        kc.contact_volumes(self.points(), self.gap_volumes(state), state.geometry, slot_of,
                           cvol, state.index,
                           state.layer_sums("cvol", cvol.shape[1], self.order_on(state),
                                            state.slot_starts))

    def gap_volumes(self, state):
        """The particle volumes the volume gap weighs the shape functions with. Under the
        hats (sampled at the particles) the current volumes, whose sum at a node is the
        integral of its hat over the body. Under uGIMP the initial ones: a weight is the
        hat's mean over the particle's undeformed domain, so V0 S_ip is the hat's
        integral over that domain, and where the domains overlap under compression the
        reading errs towards closed by about the strain. That holds a pressed contact
        closed: with the current volumes, or the domains stretched with the strain so
        that they tile (tried), the reading of touching faces is zero give or take the
        strain, and a node that a loaded body barely reached let go during an impact
        (docs/validation/two_bars.md)."""
        p = self.particles
        if state.shape == GIMP:
            return p.vol0
        volume = self.work.empty("volume", p.n, 1)[:, 0]
        return np.divide(p.mass, p.rho, out=volume)

    def stress_and_forces(self, state, dt, contact):
        """USF: stresses from the start-of-step nodal velocities and the nodal forces in one
        pass. Returns the fastest wave plus particle speed, as the speed that gives the
        same Courant number on the coarse grid."""
        return self.particle_pass(state, dt, contact, True, True)

    def scatter_forces(self, state, contact):
        """MUSL: nodal forces from the stresses of the start of the step (Eqs. 31-32)."""
        self.particle_pass(state, 0.0, contact, False, True)

    def update_stresses(self, state, dt, contact):
        """MUSL: stresses from the nodal velocities mapped back from the updated particle
        velocities. Returns the speed as :meth:`stress_and_forces`."""
        return self.particle_pass(state, dt, contact, True, False)

    def particle_pass(self, state, dt, contact, stresses, forces):
        lv = state.level
        fastest, bad = mpm.stress_and_forces(
            self.points(), self.particles.material, self.materials, self.loads(), dt, lv.h,
            state.geometry, state.gvel, state.force, contact, state.index, stresses, forces,
            state.layer_sums("force", 3, self.order_on(state)) if forces else None,
            state.layer_sums("cforce", contact.cforce.shape[1] * 3, self.order_on(state),
                             state.slot_starts) if forces and contact is not None else None)
        self.note_fault(bad, FAILED_UPDATE)
        return fastest * lv.ratio

    def grid_to_points(self, state, dt, contact):
        bad = mpm.grid_to_particles(self.points(), self.bodies.rigid, dt, state.geometry,
                                    state.gnew, contact, state.index, self.pic,
                                    self.affine())
        self.note_fault(bad, "position is not finite")

    # -- MUSL: the stress update runs at the start-of-step positions --------------------
    def remember_start_positions(self):
        self.x_start = self.copy_of("x_start", self.particles.x)

    def back_to_start_positions(self):
        """Keep the moved positions aside and put the particles back where the step began."""
        self.x_moved = self.copy_of("x_moved", self.particles.x)
        self.particles.x[:] = self.x_start

    def on_to_moved_positions(self):
        self.particles.x[:] = self.x_moved

    def copy_of(self, name, array):
        copy = self.work.empty(name, len(array), 3)
        copy[:] = array
        return copy

    # -- faults ------------------------------------------------------------------------
    def note_fault(self, bad, what):
        """Remember this rank's first bad particle of the step; the end-of-step reduction
        tells every rank, and every rank then raises the same error (no extra collective
        per phase)."""
        if bad >= 0 and self.fault is None:
            p = self.particles
            self.fault = (f"particle id {int(p.id[bad])} of body "
                          f"'{self.bodies.names[int(p.body[bad])]}': {what}")

    # -- outputs (pmpm.solver.kinds.BodyKind) ------------------------------------------
    def take_loads(self, vectors):
        self.load_vectors = vectors

    def energies(self):
        return (*particle_energies(self.particles), 0.0)

    def energy_sums(self):
        return particle_energy_sums(self.particles)

    def body_stats(self, world):
        return body_stats(world, self.particles, self.bodies.names, self.exact)

    def potential(self, gravity):
        p = self.particles
        return -mass_moment_along(p.mass, p.x, np.asarray(gravity, np.float64))

    def potential_sums(self, gravity):
        p = self.particles
        return moment_along_exact(p.mass, p.x, np.asarray(gravity, np.float64), -1.0)

    def load_power(self, vectors):
        return load_power(self.particles, vectors)

    def load_power_terms(self, vectors):
        p = self.particles
        return load_power_terms(p.load, p.load_scale, p.v, vectors)

    # -- ownership ---------------------------------------------------------------------
    def owners_and_spans(self, grids, grid, slabs, rank, owner):
        """Owner rank of each particle (into ``owner``, -1: left the grid box) and the
        spans of the levels (``assign_levels`` first), in one pass over x; returns how
        many left, how many of the others ``rank`` does not own, and the spans."""
        return grids.owners_and_spans(grid, slabs, rank, self.particles.x, self.level_of,
                                      owner)

    def slab_cells(self, grid, axis):
        return grid.cells_of(self.particles.x)[:, axis]

    def slab_weights(self):
        """None: a particle counts 1 in the slabs' balance (solver.work_weights)."""
        return None

    def sort_by_cell(self, grid, axis=0):
        """Order particles by coarse cell so that scatter and gather walk memory in order;
        with layer-ordered sums by their canonical order (the slab ``axis`` slowest, then
        id), which then stays close to the array order (cheap to sort each step)."""
        p = self.particles
        if self.exact:
            p.take(self.level_by_level_order(grid, axis))
            return
        keys = mpm.cell_keys(p.x, grid.origin, 1.0 / grid.h, grid.n_cells)
        p.take(np.argsort(keys, kind="stable"))

    # -- particles from elsewhere -------------------------------------------------------
    def add_particles(self, columns):
        """Take particles that another body kind hands over in a step (a transfer,
        pmpm.solver.transfer) or that splitting makes (:meth:`split_entering`;
        ``columns``: name -> array, every column of the store):
        appended at the end of the store; the next step gives them their grid levels,
        and the end of this one their ranks, like the others. Returns how many."""
        self.particles.append(columns)
        return len(columns["mass"])

    def level_by_level_order(self, grid, axis):
        """The coarse grid's particles, then each window's, each in its level's
        canonical order: the order each level's layered scatters visit them in, so that
        they walk memory in order (a window's cell layers interleave within a coarse
        layer: visited in the coarse order, the window's kernels ran 3 times slower)."""
        if not self.windows:
            return self.canonical_order(grid.origin, 1.0 / grid.h, grid.n_cells, axis)
        self.assign_levels(grid, self.windows)          # the levels of the moved particles
        ratios = [1] + [w.ratio for w in self.windows]
        order = np.concatenate([self.canonical_order(grid.origin, r / grid.h,
                                                     grid.n_cells * r, axis, k)
                                for k, r in enumerate(ratios)])
        self.level_of = self.level_of[order]
        return order

    # -- refinement (seed 000 Sec. 3.4) -------------------------------------------------
    def split_entering(self, ratios, id_base, id_stride):
        """Split every particle whose spacing is coarser than the window it is in: a
        particle of ``refine`` r in a window of ratio R becomes (R // r)^3 particles."""
        p = self.particles
        factors = ratios[self.level_of] // p.refine
        parents = np.flatnonzero(factors >= 2)
        if len(parents):
            self.add_particles(split(p, parents, factors[parents], id_base, id_stride))

    def layer_moments(self, body, grid, axis):
        """Per coarse cell layer along the slab ``axis``, (n_layers, 4): sum m x and sum
        m of one body's particles by their layer at the step's start (that of the last
        mass scatter), each layer's added in id order. That layer's particles are all on
        the rank whose slab held it, so a SUM over ranks of these rows gives each row one
        rank's value, the same as one rank's (solver.refine)."""
        p = self.particles
        mine = np.flatnonzero(p.body == body)
        layer = self.slab_layer if len(self.slab_layer) == p.n else \
            np.floor((p.x[:, axis] - grid.origin[axis]) / grid.h).astype(np.int64)
        layer = np.clip(layer[mine], 0, grid.n_cells[axis] - 1)
        order = np.lexsort((p.id[mine], layer))
        sums = np.zeros((int(grid.n_cells[axis]), 4))
        tied.layer_moments(p.x[mine], p.mass[mine], order, layer, sums)
        return sums

    def mass_moments(self, body):
        """(sum m x, sum m) of one body's particles, for its centroid."""
        p = self.particles
        mine = p.body == body
        return p.mass[mine] @ p.x[mine], p.mass[mine].sum()


NO_ORDER = np.zeros(0, np.int64)
FAILED_UPDATE = "constitutive update failed (NaN, non-convergence or non-positive density)"
