"""The body kinds and the parts of a run, built from registries keyed by the case's
names.

The body kinds beyond the particles (which every run has: the material of the other
kinds may become particles) are keyed by the ``method`` of the bodies they carry
(``bodies[i].method``, :data:`KINDS`): each :class:`KindEntry` builds its kind from the
initial layout or from a checkpoint's row sets.

A part is a coupling of the step (pmpm.solver.couplings: what ties the fields together
beyond one body on one grid), a body kind that a coupling brings (pmpm.solver.kinds: the
grid-coupled FE nodes), or a transfer (pmpm.solver.transfer: material that moves from one
kind to another in a step). Each :class:`Entry` names the part, the case key that asks
for it, its role, and the function that builds it from the :class:`Setup` (what the
simulation has built so far, the parts before it included), or returns None when the
case does not ask for it. The registry's order is the order in which the parts are built
and in which the step calls the couplings' hooks: grid contact before what reads its
fields, the force log last. A part that a checkpoint keeps names its scalar there
(:class:`Kept`).

Each entry also declares the warm-up's kernels it needs for a case (``warms(config)``:
names of :data:`pmpm.kernels.warmup.ALL_COUPLINGS`), which the warm-up asks for before
anything is built (:func:`kernels_to_warm`).

Adding a coupling or a transfer is its module plus one entry here (with its case keys in
pmpm/case); the simulation, the step and the warm-up do not change.
"""
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..case.config import converted_into
from .contact import SURFACE_COUPLING, GridContact, start_shares
from .conversion import build_conversion
from .couplings import TiedInterface
from .fem_bodies import FemBodies
from .fem_grid import grid_coupled_nodes
from .forces import ForceLog
from .node_contact import NodeContact, check_node_contact, node_contact_pairs
from .rigid_particles import free_rigid_particles
from .surface_contact import SurfaceContact

__all__ = ["COUPLING", "KIND", "KINDS", "PARTS", "TRANSFER", "Entry", "KindEntry", "Kept",
           "Setup", "build_parts", "initial_kinds", "kernels_to_warm", "restored_kinds"]

#: the roles of the parts: where the simulation hands them to the step
COUPLING, KIND, TRANSFER = "coupling", "kind", "transfer"


def no_kernels(config):
    """What a part that needs no kernel of the warm-up's couplings declares."""
    return ()


@dataclass(frozen=True)
class KindEntry:
    """A body kind keyed by the ``method`` of the bodies it carries: ``name`` (the
    simulation's attribute for it, None when no body has the method),
    ``initial(world, config, bodies, grid, slabs, layout)`` -> (the kind, the problems of
    its set-up) from the initial layout (``Simulation.lay_out``'s ``meshes``), and
    ``restored(world, config, bodies, grid, slabs, groups)`` -> the kind from a
    checkpoint's row sets; ``warms``: the warm-up's kernels of the kind."""
    method: str
    name: str
    initial: Callable
    restored: Callable
    warms: tuple = ()


def initial_fem_bodies(world, config, bodies, grid, slabs, meshes):
    """The FEM bodies of the initial meshes, with their loads (the problems of those)."""
    elements = FemBodies(meshes, config, bodies, world, grid, slabs)
    problems = elements.assign_loads(config.loads, bodies.names)
    elements.forget_whole_mesh()
    return elements, problems


def restored_fem_bodies(world, config, bodies, grid, slabs, groups):
    return FemBodies.from_checkpoint(groups["elements"], groups["nodes"], config, bodies,
                                     world, grid, slabs)


#: the body kinds beyond the particles, by the ``method`` of their bodies, in the order
#: their parts are summed (after the particles)
KINDS = (KindEntry("fem", "elements", initial_fem_bodies, restored_fem_bodies, ("fem",)),)


def asked_kinds(config):
    """The entries of :data:`KINDS` whose method some body of ``config`` has."""
    methods = {body.method for body in config.bodies}
    return [entry for entry in KINDS if entry.method in methods]


def initial_kinds(world, config, bodies, grid, slabs, layout):
    """({name: kind} of the case's kinds beyond the particles, the problems of their
    set-up) from the initial layout."""
    kinds, problems = {}, []
    for entry in asked_kinds(config):
        kinds[entry.name], more = entry.initial(world, config, bodies, grid, slabs, layout)
        problems += more
    return kinds, problems


def restored_kinds(world, config, bodies, grid, slabs, groups):
    """{name: kind} of the case's kinds beyond the particles, from a checkpoint."""
    return {entry.name: entry.restored(world, config, bodies, grid, slabs, groups)
            for entry in asked_kinds(config)}


@dataclass(frozen=True)
class Kept:
    """How a checkpoint keeps a part: its scalar's ``key``, the value written when the
    case has no such part (``absent``), and how the value is read off the part
    (``save(part)``) and put back (``load(part, value)``; not called for a value that
    is missing or empty)."""
    key: str
    absent: Any = None
    save: Callable = lambda part: part.state()
    load: Callable = lambda part, value: part.restore(value)


@dataclass(frozen=True)
class Entry:
    """One part of the registry: ``name`` (the simulation's attribute for it, None when
    the case does not ask for it), ``key`` (the case key that asks for it), ``role``,
    ``build(setup)`` (the part, or None), ``kept`` (a Kept, or None) and
    ``warms(config)`` (the names of the warm-up's kernels the part needs for the case,
    pmpm.kernels.warmup.ALL_COUPLINGS: it must name whatever a part it would build
    calls in the steps)."""
    name: str
    key: str
    role: str
    build: Callable
    kept: Kept = None
    warms: Callable = no_kernels


@dataclass
class Setup:
    """What the parts are built from: the simulation's grid, decomposition, kinds and
    contact rules, and the parts built so far (``built``, by name, in registry order)."""
    world: Any
    config: Any
    grid: Any
    bodies: Any
    points: Any
    elements: Any
    decomposition: Any
    rules: Any
    windows: list
    n_levels: int
    m_tiny: float
    n_total: int
    #: the parts built so far, by name
    built: dict = field(default_factory=dict)
    #: the couplings built so far, in step order: the list the step will run (later
    #: couplings are appended to it as they are built)
    couplings: list = field(default_factory=list)

    def part(self, name):
        """The part built under ``name``, or None."""
        return self.built.get(name)


# -- the builders, one per entry ---------------------------------------------------------
def tied_interface(setup):
    return TiedInterface(setup.world) if setup.windows else None


def grid_contact(setup):
    if not setup.rules.active:
        return None
    return GridContact(setup.rules, setup.world, setup.bodies, setup.m_tiny, setup.n_levels,
                       start_shares(setup.config))


def rigid_particles(setup):
    """After the grid contact, whose fields it reads, before the points move."""
    return free_rigid_particles(setup.config, setup.world, setup.points,
                                setup.part("grid_contact"))


def grid_coupled_fe_nodes(setup):
    """The FE nodes of grid-coupled FEM bodies as a kind on the grid."""
    s = setup
    nodes = grid_coupled_nodes(s.config, s.rules, s.elements, s.couplings, s.decomposition,
                               s.grid, s.bodies, s.m_tiny, s.points)
    return nodes[0] if nodes else None


def surface_contact(setup):
    """Where a particle body meets an FEM body by surface coupling, or particles may be
    born of an FEM body's elements (``BodyTable.born_spacing``: they meet what is left
    of the mesh)."""
    elements, config = setup.elements, setup.config
    if not elements:
        return None
    fem = np.array([b.is_fem for b in config.bodies])
    surface = setup.rules.coupling == SURFACE_COUPLING
    born = bool(setup.bodies.meets_own_mesh.any())
    if not ((surface & (fem[:, None] != fem[None, :])).any() or born):
        return None
    return SurfaceContact(setup.rules, setup.world, setup.points, elements, setup.grid,
                          setup.decomposition)


def node_contact(setup):
    """Where two FEM bodies meet by surface coupling (node-to-surface contact)."""
    elements = setup.elements
    if not elements:
        return None
    touches = node_contact_pairs(setup.rules, elements.body_indices,
                                 elements.materials.rigid)
    if not touches.any():
        return None
    check_node_contact(setup.config, setup.rules, touches)
    return NodeContact(setup.rules, setup.world, elements, setup.grid)


def force_log(setup):
    """Last of the couplings (it reads their fields); the surface couplings and the FEM
    bodies tell it their impulses."""
    if not setup.config.output.forces:
        return None
    log = ForceLog(setup.config, setup.world, setup.bodies, setup.m_tiny,
                   setup.part("grid_contact"))
    for part in (setup.part("surface"), setup.part("node_contact"), setup.elements):
        if part is not None:
            part.force_log = log
    if setup.elements is not None:
        log.fem_supported = supported_fem_bodies(setup.world, setup.elements,
                                                 len(setup.bodies.names))
    return log


def supported_fem_bodies(world, elements, n_bodies):
    """The FEM bodies with constrained nodes (on any rank), in body order."""
    held = np.zeros(n_bodies)
    for b in np.unique(elements.node_body[elements.fixed.any(axis=1)]):
        held[b] = 1.0
    return [int(b) for b in np.flatnonzero(world.max(held))]


def set_deepest(contact, value):
    """A contact's deepest penetration of the run so far, from a checkpoint."""
    contact.deepest = value


# -- what the parts warm up, from the case alone (before anything is built) -------------
def named_couplings(config):
    """The couplings the case names (``contact.coupling`` and its pairs')."""
    return {config.contact.coupling} | {p.coupling for p in config.contact.pairs}


def with_grid_contact(config):
    """Whether grid contact may run: a contact method and two bodies or more."""
    return config.contact.method > 0 and len(config.bodies) > 1


def fem_and_particles(config):
    """(whether some body is FEM, whether some body is particles)."""
    fem = [b.is_fem for b in config.bodies]
    return any(fem), not all(fem)


def warms_free_rigid(config):
    """The force log's impulses of free rigid particle bodies."""
    free = any(not b.is_fem and b.free_axes for b in config.bodies)
    return ("free_rigid",) if with_grid_contact(config) and free else ()


def warms_fem_grid(config):
    fem, particles = fem_and_particles(config)
    grid = "grid" in named_couplings(config)
    return ("fem_grid",) if fem and particles and with_grid_contact(config) and grid else ()


def warms_surface(config):
    """Where surface coupling may meet particles, or particles may be born of an FEM
    body's elements."""
    fem, particles = fem_and_particles(config)
    born = any(b.born_spacing and into < 0
               for b, into in zip(config.bodies, converted_into(config.bodies)))
    return ("surface",) if fem and ("surface" in named_couplings(config) and particles
                                    or born) else ()


def warms_node_contact(config):
    fem = sum(b.is_fem for b in config.bodies)
    return ("node_contact",) if "surface" in named_couplings(config) and fem > 1 else ()


def warms_forces(config):
    return ("forces",) if config.output.forces else ()


#: every part a case may ask for, in build and step order
PARTS = (
    Entry("tied_interface", "grid.windows", COUPLING, tied_interface),
    Entry("grid_contact", "contact.method", COUPLING, grid_contact),
    Entry("rigid_particles", "bodies[i].rigid.free", COUPLING, rigid_particles,
          warms=warms_free_rigid),
    Entry("grid_nodes", "contact.coupling: grid", KIND, grid_coupled_fe_nodes,
          warms=warms_fem_grid),
    Entry("surface", "contact.coupling: surface", COUPLING, surface_contact,
          Kept("surface_deepest", 0.0, SurfaceContact.deepest_centre, set_deepest),
          warms=warms_surface),
    Entry("node_contact", "contact.coupling: surface", COUPLING, node_contact,
          Kept("node_deepest", 0.0, NodeContact.deepest_node, set_deepest),
          warms=warms_node_contact),
    Entry("conversion", "bodies[i].fem.convert", TRANSFER, build_conversion,
          Kept("convert")),
    Entry("force_log", "output.forces", COUPLING, force_log, Kept("forces"),
          warms=warms_forces),
)


def kernels_to_warm(config, registry=PARTS):
    """The names of the warm-up's coupling kernels (pmpm.kernels.warmup.ALL_COUPLINGS)
    that the case's kinds and the registry's parts declare for ``config``."""
    names = {name for entry in asked_kinds(config) for name in entry.warms}
    return names | {name for entry in registry for name in entry.warms(config)}


def build_parts(setup, registry=PARTS):
    """Build every part the case asks for, in registry order: {name: part} (only those
    built), with the couplings also appended, in order, to ``setup.couplings``."""
    for entry in registry:
        part = entry.build(setup)
        if part is None:
            continue
        setup.built[entry.name] = part
        if entry.role == COUPLING:
            setup.couplings.append(part)
    return dict(setup.built)
