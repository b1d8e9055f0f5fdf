"""The body kinds of a run as one abstraction.

A body kind is one way a rank carries material: the particles
(:class:`pmpm.solver.particle_bodies.ParticleBodies`), finite elements with their own
nodes (:class:`pmpm.solver.fem_bodies.FemBodies`), and the FE nodes of grid-coupled
bodies as points of the grid (:class:`pmpm.solver.fem_grid.FemGridNodes`). The step
(:class:`pmpm.solver.step.Stepper`) keeps one list of kinds and asks each only for what
its capabilities declare; the simulation sums the outputs (energies, body statistics,
potential, load power) over the same list, in its order. A kind answers what it does
not do with the defaults below: nothing, or zero.
"""
import numpy as np

from ..kernels import exact_sum

__all__ = ["BodyKind"]


class BodyKind:
    """The base of the body kinds: capabilities off, outputs zero.

    Capabilities (class attributes)
    -------------------------------
    on_grid : its points map to the grid levels: ``scatter_mass_momentum(state)``,
        ``stress_and_forces(state, dt, view)`` (USF) or ``scatter_forces(state, view)`` and
        ``update_stresses(state, dt, view)`` (MUSL), ``grid_to_points(state, dt, view)``
    owns_nodes : it has nodes of its own, advanced by central differences:
        ``advance_nodes(dt)`` (stresses, forces, trial velocities) before the grid's forces
        are summed, ``move(dt)`` once the grid has updated the points; its ``speed`` is
        its part of the step's fastest speed
    follows_slabs : its points take grid levels, move to the rank of their slab every
        step and split in refined windows (``owners_and_spans``, ``assign_levels``,
        ``split_entering``, ``sort_by_cell``: the particles)
    rebalances : it moves to the ranks of the new slabs when the decomposition
        rebalances (``migrate(grid, slabs)``), and weighs in the balance by
        ``slab_cells``/``slab_weights`` (the elements)
    """

    on_grid = False
    owns_nodes = False
    follows_slabs = False
    rebalances = False
    #: the first fault a phase met (a message), or None
    fault = None
    #: with ``owns_nodes``: the coarse-grid speed of the same Courant number as its step
    speed = 0.0
    #: what :meth:`elements_changed` calls, in the order they were added
    element_listeners = ()
    #: how many times the elements changed: what depends on the mesh alone (the free
    #: faces) may be kept while it stays, the same on every rank (the event is collective)
    mesh_version = 0
    #: what :meth:`elements_changed` last did to the elements, for the couplings that
    #: update what they keep rather than rebuild it (``remove_elements`` sets it:
    #: (the version it changed, the elements kept, the removed faces' node ids)), or None
    last_removal = None
    #: what a coupling derived from the mesh alone and keeps while ``mesh_version``
    #: stays (pmpm.solver.surface_contact.mesh_faces: the free faces and the nodes'
    #: holders, shared by surface and node contact), or None
    face_cache = None

    def when_elements_change(self, listener):
        """Have ``listener()`` called each time this kind's set of elements changes
        (:meth:`elements_changed`): the couplings that keep what depends on the mesh
        (free faces, halos) listen, so that whatever changed the elements need not know
        them."""
        self.element_listeners = (*self.element_listeners, listener)

    def elements_changed(self):
        """Raised by the kind, collectively, once its elements have changed (removed,
        or moved to other ranks): every listener rebuilds what depends on them."""
        self.mesh_version += 1
        for listener in self.element_listeners:
            listener()

    def take_loads(self, vectors):
        """The load vectors of the case's loads at the step's mid-time."""

    def energies(self):
        """(kinetic, internal, hourglass) of this rank's part."""
        return np.zeros(3)

    def energy_sums(self):
        """With exact sums: (kinetic, internal, hourglass) of this rank's part as an
        exact accumulator (pmpm.kernels.exact_sum)."""
        return exact_sum.zeros(3)

    def body_stats(self, world):
        """Per body name this kind carries, its summary entry over all ranks
        (collective)."""
        return {}

    def potential(self, gravity):
        """-sum m g.x of this rank's part."""
        return 0.0

    def potential_sums(self, gravity):
        """With exact sums: -sum m g.x of this rank's part as an exact accumulator."""
        return exact_sum.zeros(1)

    def load_power(self, vectors):
        """The loads' power on this rank's part."""
        return 0.0

    def load_power_terms(self, vectors):
        """With exact sums: the loads' power on each of this rank's loaded points."""
        return np.zeros(0)

    def element_count(self):
        """The elements this rank holds."""
        return 0
