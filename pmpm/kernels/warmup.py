"""Compile (or load from Numba's cache) every kernel of the step on a one-particle
problem, with the argument types the step uses (contact view absent and present), so
that compile time is measured apart from run time."""
import time

import numpy as np

from ..materials import layout
from ..materials.state import MaterialState
from . import boundary, contact, exact_sum, mpm, observe, tied
from .cache import refresh_kernel_caches
from .portable import cube_roots
from .shape import HALO, LINEAR, MARKERS, SHAPE_CODES
from .warmup_fem import warm_up_couplings
from .records import (BodyMaterials, ContactSlots, ContactView, ExternalLoads, GridGeometry,
                      LayerSums, NodeBlock, PairRules, PointState, TieSet)

N = 27   # nodes of the warm-up block


#: every kind of :func:`kernels_of` beyond the MPM step's: the FEM bodies, their
#: couplings, the force log (pmpm.kernels.warmup_fem)
ALL_COUPLINGS = {"fem": True, "surface": True, "node_contact": True, "fem_grid": True,
                 "forces": True, "free_rigid": True}


def warm_up_layers(order, width, shape_code):
    """A LayerSums record over the warm-up block (its 3 node planes of 9 nodes)."""
    halo = HALO[shape_code]
    return LayerSums(order, 0, np.arange(4, dtype=np.int64) * 9, halo,
                     np.zeros((27, width)), np.zeros((1, 9, width)))


def layer_variants(order, width, shape_code, exact):
    """The ``layers`` arguments a scatter takes: None, and with ``exact`` a LayerSums."""
    return (None, warm_up_layers(order, width, shape_code)) if exact else (None,)


def warm_up_defaults():
    """Compile (or load) the step's kernels for the hats and for the default shape
    functions with the APIC variants, the FEM bodies' and couplings' with them, and the
    layer-ordered sums' variants (``grid.exact_sums``, on by default where bodies touch):
    what scripts/setup.sh compiles while h5py builds, and the test session before its
    first test. Returns the seconds spent."""
    from ..case.schema import GRID
    return warm_up(LINEAR, exact=True, **ALL_COUPLINGS) + \
        warm_up(SHAPE_CODES[GRID["shape_functions"].default], apic=True, exact=True,
                **ALL_COUPLINGS)


def warm_up(shape_code=LINEAR, apic=False, contact=True, ties=True, mirrors=True,
            exact=False, **couplings):
    """Return the seconds spent compiling or loading the kernels (for the shape functions
    ``shape_code``, a ``pmpm.kernels.shape`` code: each shape has its own compiled kernels;
    with ``apic`` also the transfers' affine variants). ``contact``, ``ties`` and
    ``mirrors`` (grid contact, refined windows, planes of symmetry) also take their
    kernels: a run leaves out those of what it does not use (each costs some 20 ms to
    load from the cache, a second for all of them: :func:`kernels_of`). The keywords
    ``couplings`` (``fem``, ``surface``, ``node_contact``, ``fem_grid``, ``forces``,
    ``free_rigid``, true or false) take the FEM bodies', their couplings' and the force
    log's kernels (pmpm.kernels.warmup_fem). ``exact`` adds the layer-ordered sums'
    variants (``grid.exact_sums``)."""
    started = time.perf_counter()
    refresh_kernel_caches()
    # 3 x 3 x 3 nodes: what a 27-node shape reaches from the point at (0.5, 0.5, 0.5)
    lo, strides, shape = np.zeros(3, np.int64), np.array([9, 3, 1], np.int64), np.full(3, 3, np.int64)
    n_cells = np.full(3, 2, np.int64)
    geo = GridGeometry(np.zeros(3), 1.0, lo, strides, MARKERS[shape_code],
                       np.full(1, 0.25))
    block = NodeBlock(shape, lo, strides, n_cells, np.zeros(6, np.int64), np.zeros(N, np.uint16),
                      np.zeros(6))
    pts = PointState(np.full((1, 3), 0.5), np.zeros((1, 3)), np.ones(1),
                     np.zeros(1, np.int32), np.zeros(1, np.int32))
    rigid = np.zeros(1, np.bool_)
    prm = np.zeros((1, layout.N_SLOTS))
    prm[0, [layout.RHO0, layout.E, layout.G, layout.K]] = 1.0
    bodies = BodyMaterials(np.zeros(1, np.int64), prm, rigid)
    mat = MaterialState(np.zeros((1, 6)), np.eye(3).reshape(1, 9).copy(), np.ones(1),
                        np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1),
                        np.zeros(1))
    loads = ExternalLoads(np.zeros(3), np.zeros((1, 3)), np.full(1, -1, np.int32), np.zeros(1))
    nodal = np.zeros((N, mpm.NODAL_COMPONENTS))
    gvel, force, gnew = np.zeros((N, 3)), np.zeros((N, 3)), np.zeros((N, 6))
    # the particle bodies pass their affine matrices, None without APIC, and the
    # grid-coupled FE nodes None: an omitted argument would be another signature
    affine = np.zeros((1, 9)) if apic else None
    pairs = boundary.mirror_pairs(block)
    slots, view = warm_up_contact(pts, geo, block, gvel, gnew, affine, shape_code, exact) \
        if contact else (None, None)
    order = np.zeros(1, np.int64)
    for layers in layer_variants(order, mpm.NODAL_COMPONENTS, shape_code, exact):
        mpm.particles_to_grid(pts, rigid, geo, nodal, 0, None, layers)
        if apic:
            mpm.particles_to_grid(pts, rigid, geo, nodal, 0, affine, layers)
    mpm.nodal_velocities(nodal, block, 0.0, gvel)
    mpm.integrate_nodes(nodal, force, gvel, 1e-3, block, 0.0, gnew)
    for contact_view in (None, view) if contact else (None,):
        for layers in layer_variants(order, 3, shape_code, exact):
            clayers = None if layers is None or contact_view is None else layers
            mpm.stress_and_forces(pts, mat, bodies, loads, 1e-3, 1.0, geo, gvel, force,
                                  contact_view, 0, True, True, layers, clayers)
        mpm.grid_to_particles(pts, rigid, 1e-3, geo, gnew, contact_view, 0, 0.0, None)
        if apic:
            mpm.grid_to_particles(pts, rigid, 1e-3, geo, gnew, contact_view, 0, 0.0, affine)
    x, level = pts.x, pts.level
    mpm.slab_cell_keys(x, geo.origin, 1.0, n_cells, 0)
    keys = np.zeros(1, np.int64)
    mpm.canonical_keys(x, np.zeros(1, np.int64), geo.origin, 1.0, n_cells, 0, keys)
    mpm.sort_nearly_sorted(keys, np.zeros(1, np.int64), 4)
    cube_roots(np.ones(1))
    ones, zeros3 = np.ones(1), np.zeros((1, 3))
    observe.body_sums(pts.body, ones, x, zeros3, ones, ones, ones, 1)   # history rows
    observe.kinetic_and_internal(ones, zeros3, ones)
    observe.mass_moment_along(ones, x, np.zeros(3))
    if exact:                                          # history rows with exact sums
        observe.body_sums_exact(pts.body, ones, x, zeros3, ones, ones, ones, 1)
        observe.energy_sums_exact(ones, zeros3, ones)
        observe.moment_along_exact(ones, x, np.zeros(3), -1.0)
        exact_sum.add_terms(exact_sum.zeros(1), 0, ones)
        exact_sum.add_rows(exact_sum.zeros(1), 0, np.zeros((1, 1)))
        exact_sum.carry_all(exact_sum.zeros(1))
    owner, ratios = np.zeros(1, np.int64), np.ones(1, np.int64)
    mpm.classify_particles(x, geo.origin, 1.0, n_cells, 0, np.array([0, 1], np.int64), 0,
                           owner)
    mpm.level_spans(x, level, geo.origin, 1.0, n_cells, ratios, np.ones(1), np.zeros(6))
    mpm.owners_and_spans(x, level, geo.origin, 1.0, n_cells, 0, np.array([0, 1], np.int64),
                         0, ratios, np.ones(1), owner, np.zeros(6))
    if ties:
        warm_up_ties(pts, geo, block, nodal)
    boundary.fill_face_codes(shape, lo, strides, n_cells, block.boundary, block.friction,
                             block.faces)
    if mirrors:
        warm_up_mirrors(block, pairs, nodal)
    warm_up_couplings(pts, geo, block, pairs, mat, bodies, (nodal, force, gvel, gnew),
                      (slots, view) if contact else None, dict(couplings, exact=exact),
                      affine)
    return time.perf_counter() - started


def kernels_of(config):
    """The keyword arguments of :func:`warm_up` for a case (a ``pmpm.case.Config``):
    grid contact with a contact method and two bodies or more (pmpm.solver.contact.
    ContactRules.active), ties with refined windows, mirrors with a face the 27-node
    shapes reflect across (symmetry, fixed, slip without friction: pmpm.kernels.boundary.
    mirrors), the layer-ordered sums' variants with ``grid.exact_sums``; and of
    :data:`ALL_COUPLINGS` those that the case's body kinds and parts declare (each entry
    of pmpm.solver.registry says which it needs: ``warms``)."""
    from ..solver.registry import kernels_to_warm    # the parts know what they call
    declared = kernels_to_warm(config)
    contact = config.contact.method > 0 and len(config.bodies) > 1
    return {"apic": config.time.transfer == "apic", "contact": contact,
            "ties": bool(config.grid.windows), "mirrors": _mirrors(config.grid),
            "exact": config.grid.exact_sums,
            **{name: name in declared for name in ALL_COUPLINGS}}


def _mirrors(grid):
    """Whether a 27-node shape's nodes beyond a box face have images (kernel mirrors)."""
    if grid.shape_functions == "linear":
        return False
    return any(kind in ("symmetry", "fixed") or
               (kind == "slip" and not (grid.friction or {}).get(face, 0.0))
               for face, kind in grid.boundary.items())


def warm_up_contact(pts, geo, block, gvel, gnew, affine=None, shape_code=LINEAR,
                    exact=False):
    """The contact kernels; returns the (empty) slots and view they leave."""
    mask, slot_of = np.zeros(N, np.int64), np.zeros(N, np.int64)
    contact.body_masks(pts, geo, mask, 0)
    slot_nodes = contact.number_contact_nodes(mask, slot_of)
    cnodal = np.zeros((0, 1, contact.CNODAL))
    cvel, cforce, cnew = np.zeros((0, 1, 3)), np.zeros((0, 1, 3)), np.zeros((0, 1, 6))
    for layers in layer_variants(np.zeros(1, np.int64), contact.CNODAL, shape_code, exact):
        contact.contact_particles_to_grid(pts, geo, slot_of, cnodal, 0, None, layers)
        if affine is not None:
            contact.contact_particles_to_grid(pts, geo, slot_of, cnodal, 0, affine, layers)
    boundary.mirror_masks(mask, boundary.mirror_pairs(block))
    slots = ContactSlots(cnodal, slot_nodes, cvel, cvel.copy(), cforce, cnew)
    rules = PairRules(np.zeros((1, 1), np.int64), np.zeros((1, 1)), np.full((1, 1), np.inf))
    rigid = np.zeros(1, np.bool_)
    contact.contact_start(slots, gvel, rules, rigid, 2, 0.0, block, 0.0)
    contact.contact_end(slots, gvel, gnew, rules, rigid, contact.SKIP_FRICTIONLESS, 1e-3,
                        0.0, block, np.zeros(rigid.shape[0]))
    cext = np.full((0, 1, contact.CEXT), -np.inf)
    contact.contact_extents(pts, geo, slot_of, cext, 0)
    cvol = np.zeros((0, 1))
    for layers in layer_variants(np.zeros(1, np.int64), 1, shape_code, exact):
        contact.contact_volumes(pts, np.ones(len(pts.x)), geo, slot_of, cvol, 0, layers)
    contact.release_open_gaps(slots, cext, cvol, np.zeros((1, 1)), geo.half_width, 0.0,
                              block)
    contact.balance_start(slots, rigid, 0.0, block)
    return slots, ContactView(slot_of, cvel, cforce, cnew)


def warm_up_ties(pts, geo, block, nodal):
    """The tied-interface kernels (pmpm.kernels.tied)."""
    x, level = pts.x, pts.level
    tied.particle_levels(x, geo.origin, 1.0, np.zeros((1, 3), np.int64),
                         np.ones((1, 3), np.int64), level)
    level[:] = 0
    mask = np.zeros(N, np.int64)
    tied.mark_occupied(x, level, geo.origin, 1.0, geo.lo, geo.strides, mask)
    ties = TieSet(np.zeros(N, np.int64), np.zeros((N, 8), np.int64), np.zeros((N, 8)), 0)
    count = tied.find_ties(block, block.lo, block.lo + 1, 2, block, mask, ties)
    ties = ties._replace(count=count)
    tied.find_inner_ties(block, block, block.lo, block.lo, block.lo, block.lo, 1, ties)
    tied.slaves_to_masters(ties, nodal, nodal)
    rows = np.array([0, N], np.int64)
    tied.slaves_to_masters_in_rows(ties, nodal, nodal, rows, rows)
    tied.masters_to_slaves(ties, nodal, nodal)
    tied.clear_slave_slots(ties, mask)
    tied.mark_slaves(ties, np.zeros(N, np.int8))


def warm_up_mirrors(block, pairs, nodal):
    """The planes of symmetry's kernels (pmpm.kernels.boundary), on node rows and on
    contact slots (``pairs``: the block's mirror pairs)."""
    kinds = boundary.column_kinds(nodal.shape[1], velocity=(1,))
    boundary.mirror_rows(nodal[:, None, :], kinds, pairs, block.boundary, None, None)
    boundary.mirror_rows(nodal[:, None, :], kinds, pairs, block.boundary, None,
                         np.zeros(N, np.int8))
    slot_of = np.full(N, -1, np.int64)
    cnodal = np.zeros((0, 1, contact.CNODAL))
    for tied in (None, np.zeros(N, np.int8)):
        boundary.mirror_rows(cnodal, kinds[:1].repeat(contact.CNODAL), pairs, block.boundary,
                             slot_of, tied)
        boundary.mirror_rows(np.zeros((0, 1, 3))[:, :, 0][:, :, None], kinds[:1], pairs,
                             block.boundary, slot_of, tied)
    boundary.mirror_extents(np.zeros((0, 1, contact.CEXT)), pairs, slot_of)
