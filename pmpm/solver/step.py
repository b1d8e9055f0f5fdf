"""One explicit step (DESIGN.md "One time step") as named phases over the coarse grid and
any refined windows tied to it (seed 000 Sec. 4). The scheme (USF or MUSL) orders the
phases; each phase calls its method on every body kind for its points' part on every
grid level and its hook on every coupling (tied interface, grid contact): the objects
the simulation built from the registries (pmpm.solver.registry) answer, no name is
looked up."""
from ..kernels import mpm
from ..kernels.boundary import column_kinds

#: how ``nodal`` (mass, momentum, rigid mass, rigid momentum) and ``force`` reflect
NODAL_KINDS = column_kinds(mpm.NODAL_COMPONENTS, velocity=(1, 5))
FORCE_KINDS = column_kinds(3, velocity=(0,))

__all__ = ["Stepper"]


class Stepper:
    """Advances the body kinds of one rank by one time step, in step with the other ranks.

    Parameters
    ----------
    decomposition : solver.decomposition.Decomposition   slabs, cell ranges, migration
    grids : solver.levels.Hierarchy   the coarse grid and the windows on this rank
    kinds : list of solver.kinds.BodyKind   every body kind of the run, in the order their
        parts are summed; each is asked for what its capabilities declare: ``on_grid``
        (particles, grid-coupled FE nodes) in the grid phases, ``owns_nodes`` (FEM bodies)
        for their stresses, forces and trial velocities before the grid's forces are
        summed and their positions when the points move, ``follows_slabs`` (particles)
        for grid levels, migration and splitting
    couplings : list of solver.couplings.Coupling   (tied interface, grid contact)
    scheme : a scheme of pmpm.solver.schemes
    refiner : solver.refine.Refiner   windows that move, particles that split
    m_tiny : float   nodal mass below which a node counts as empty
    transfers : list of solver.transfer.Transfer   the registry's transfers, whose
        ``transfer()`` moves material from one kind to another once the points have
        moved, before windows split particles and points migrate
    """

    def __init__(self, decomposition, grids, kinds, couplings, scheme, refiner, m_tiny,
                 transfers=()):
        self.decomposition, self.grids = decomposition, grids
        self.kinds, self.couplings = list(kinds), list(couplings)
        self.grid_kinds = [k for k in self.kinds if k.on_grid]
        self.node_kinds = [k for k in self.kinds if k.owns_nodes]
        self.moving_kinds = [k for k in self.kinds if k.follows_slabs]
        self.transfers = list(transfers)
        self.scheme, self.refiner, self.m_tiny = scheme, refiner, m_tiny
        self.fastest = 0.0

    def step(self, dt):
        for kind in self.kinds:
            kind.fault = None
        self.decomposition.assign_levels(self.moving_kinds)
        self.decomposition.build_blocks()
        self.scheme.advance(self, dt)
        for transfer in self.transfers:
            transfer.transfer()
        self.refiner.move_windows_and_split()
        fault = next((k.fault for k in self.kinds if k.fault), None)
        fastest = max([self.fastest] + [k.speed for k in self.node_kinds])
        self.fastest = self.decomposition.finish_step(self.moving_kinds, fastest, fault)

    # -- the phases --------------------------------------------------------------------
    def map_to_grid(self):
        """Mass and momentum on every level (Eqs. 12-13); the couplings' part before the
        sums over shared slab planes (slaves to masters, Eqs. 17, 20) and after them
        (per-body contact fields)."""
        self.grids.zeros("nodal", mpm.NODAL_COMPONENTS)
        for s, kind in self.levels_and_kinds():
            kind.scatter_mass_momentum(s)
        for coupling in self.couplings:
            coupling.after_scatter(self.grids, self.grid_kinds)
        self.grids.sum_shared("nodal")
        for coupling in self.couplings:
            coupling.before_reflect(self.grids, "nodal")
        self.grids.reflect("nodal", NODAL_KINDS)
        for coupling in self.couplings:
            coupling.after_mass_sum(self.grids, self.grid_kinds)

    def nodal_velocities(self):
        """Nodal velocities with the boundary conditions; slaves from masters (Eq. 22);
        method 2's contact correction (seed 001 Eqs. 23-25)."""
        self.grids.empty("gvel", 3)
        for s in self.grids:
            mpm.nodal_velocities(s.nodal, s.nodes, self.m_tiny, s.gvel)
        for coupling in self.couplings:
            coupling.after_velocities(self.grids)

    def stress_and_forces(self, dt):
        """USF: stress update and nodal forces on every level; slave forces to their
        masters (Eq. 18); the sums over shared slab planes."""
        self.grids.zeros("force", 3)
        self.advance_elements(dt)
        fastest = 0.0
        for s, kind in self.levels_and_kinds():
            fastest = max(fastest, kind.stress_and_forces(s, dt, self.view(s)))
        self.fastest = fastest
        self.complete_forces()

    def nodal_forces(self, dt):
        """MUSL: nodal forces from the stresses of the start of the step (Eqs. 31-32)."""
        self.grids.zeros("force", 3)
        self.advance_elements(dt)
        for s, kind in self.levels_and_kinds():
            kind.scatter_forces(s, self.view(s))
        self.complete_forces()

    def advance_elements(self, dt):
        """Central differences on the FE nodes, from the nodes alone: element stresses,
        nodal forces and trial velocities (seed 004 notes Sec. 1.5 step 4), before the
        grid's forces are summed so that grid coupling can put them on the grid."""
        for kind in self.node_kinds:
            kind.advance_nodes(dt)

    def complete_forces(self):
        for coupling in self.couplings:
            coupling.after_forces(self.grids)
        self.grids.sum_shared("force")
        for coupling in self.couplings:
            coupling.before_reflect(self.grids, "force")
        self.grids.reflect("force", FORCE_KINDS)

    def update_stresses(self, dt):
        """MUSL: the stress update from the velocities mapped back to the grid; the
        fastest wave plus point speed, as the speed that gives the same Courant number
        on the coarse grid."""
        fastest = 0.0
        for s, kind in self.levels_and_kinds():
            fastest = max(fastest, kind.update_stresses(s, dt, self.view(s)))
        self.fastest = fastest

    def integrate(self, dt):
        """Leap-frog on the nodes of every level (Eq. 14); contact forces (seed 001 Eqs.
        11-22); slaves follow their masters (Eqs. 23-24)."""
        self.grids.empty("gnew", 6)
        for s in self.grids:
            mpm.integrate_nodes(s.nodal, s.force, s.gvel, dt, s.nodes, self.m_tiny, s.gnew)
        for coupling in self.couplings:
            coupling.after_integrate(self.grids, dt)

    def update_points(self, dt):
        """Grid to points: positions and velocities (Eqs. 15-16); grid-coupled FE nodes
        take their contact correction; FE nodes move with their new half-step
        velocities; then particle-to-surface contact corrects both (seed 004 Sec. 3)."""
        for s, kind in self.levels_and_kinds():
            kind.grid_to_points(s, dt, self.view(s))
        for kind in self.node_kinds:
            kind.move(dt)
        for coupling in self.couplings:
            coupling.after_update_points(dt)

    # -- MUSL's return to the start-of-step positions (the kinds that follow the slabs)
    def remember_start_positions(self):
        for kind in self.moving_kinds:
            kind.remember_start_positions()

    def back_to_start_positions(self):
        for kind in self.moving_kinds:
            kind.back_to_start_positions()

    def on_to_moved_positions(self):
        for kind in self.moving_kinds:
            kind.on_to_moved_positions()

    # -- asking ------------------------------------------------------------------------
    def levels_and_kinds(self):
        """(level state, kind) for every grid level and every kind on the grid, level by
        level: the order in which the kinds add to the shared fields."""
        for s in self.grids:
            for kind in self.grid_kinds:
                yield s, kind

    def view(self, state):
        """What the point kernels read of the couplings' fields on a level: the first
        coupling's view that is not None (grid contact's per-body fields), else None."""
        for coupling in self.couplings:
            view = coupling.view(state)
            if view is not None:
                return view
        return None
