"""Compile (or load from Numba's cache) the kernels of the FEM bodies, of their couplings
(particle-to-surface ICFEMP, node-to-surface, grid CFEMP) and of the force log before the
step loop, as :mod:`pmpm.kernels.warmup` does for the MPM step: otherwise they compile
inside the first step, which then takes seconds (cold) or a fifth of a second (cached)
more than the others.

Numba compiles one specialisation per argument-type signature, so each kernel is called
here with exactly the types the solver passes it (int64 where the solver converts,
int32 where it keeps the mesh's int32 body columns, contiguous arrays, the same
namedtuple records); a call with another dtype or layout would compile a second variant
and leave the first step compiling still (tests/test_warmup.py counts the signatures).
The problems are empty or one element: the calls only need valid types."""
import numpy as np

from ..fem import elements as fe
from ..fem.criteria import elements_to_convert
from ..fem.hexahedron import boundary_volumes, element_volumes
from ..fem import nodes as fn
from ..fem.stability import mesh_rate
from ..materials import layout
from . import exact_sum, fem_grid, forces, node_contact, surface_contact
from .records import LayerSums
from .shape import HALO

#: the unit cube as one hexahedron (VTK order)
CUBE = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                 [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], np.float64)


def warm_up_elements(mat, bodies, exact=False):
    """The element kernels (pmpm.fem: set-up volumes, masses and stable rate, the step's
    element forces, loads and central-difference update) on one unit-cube element with
    the material state ``mat`` and table ``bodies`` of the MPM warm-up. One kernel serves
    every element formulation and hourglass form: those are data (``Hourglass.kind``)."""
    x, v = CUBE.copy(), np.zeros((8, 3))
    hexes, body = np.arange(8, dtype=np.int64)[None, :], np.zeros(1, np.int32)
    vol, mass = np.empty(1), np.empty(8)
    element_volumes(x, hexes, vol)
    boundary_volumes(x, hexes, np.empty(1))  # the conversion check's (FemBodies.volumes)
    nb, one = len(bodies.rigid), np.ones(1)
    elements_to_convert(body, one, one, one, one, one, np.zeros(nb, np.int64),
                        one.repeat(nb), one.repeat(nb), one.repeat(nb), 0.0, one.repeat(nb),
                        one.repeat(nb), np.empty(1, np.bool_))
    rho0 = np.ascontiguousarray(bodies.params[:, layout.RHO0])
    fe.lumped_masses(hexes, vol, bodies.params[body, layout.RHO0], mass)
    kind, coefficient = np.zeros(1, np.int64), np.full(1, 0.1)
    mesh_rate(x, hexes, body, rho0, np.ones(1), bodies.params, kind, coefficient)
    hourglass = fe.Hourglass(kind, coefficient, np.zeros((1, 12)), np.zeros(1))
    force = np.zeros((8, 3))
    for parts in (None, np.zeros((1, 8, 3))) if exact else (None,):   # grid.exact_sums
        fe.element_forces(fe.ElementMesh(x, v, hexes, body), mat, bodies, hourglass, 1e-3,
                          force, np.zeros(1), parts,
                          None if parts is None else np.zeros(1, np.int64))
    if exact:                           # pmpm.comm.shared_nodes.ElementOrderSums
        exact_sum.add_rows_in_order(force, hexes[0], np.zeros((8, 3)), hexes[0])
    fe.external_forces(mass, np.zeros(3), np.full(8, -1, np.int32), np.zeros(1),
                       np.zeros((1, 3)), force)
    fe.advance_velocities(v, force, mass, np.zeros((8, 3), np.bool_), 1e-3)
    warm_up_nodes(x, v, force, mass, exact)
    fe.advance_positions(x, v, 1e-3)


def warm_up_nodes(x, v, force, mass, exact=False):
    """The FE nodes' kernels (pmpm.fem.nodes) with the types FemBodies passes: one slip
    face z-, a force log's sums for one body (with ``exact`` also as exact
    accumulators, pmpm.kernels.exact_sum)."""
    movable, fixed = np.ones(len(x), np.bool_), np.zeros((len(x), 3), np.bool_)
    faces = (np.array([2], np.int64), np.array([-1.0]), np.zeros(1), np.zeros(1, np.bool_))
    for exact_sums in sums_variants(exact):
        fn.advance_and_hold(x, v, force, mass, fixed, movable, *faces, 1e-3, 1e-9, True,
                            movable.copy(), np.zeros(len(x), np.int32),
                            sums_like((1, 3), exact_sums), sums_like((6, 4), exact_sums))
    fn.hold_at_faces(x, v, movable, *faces, 0.0, 1e-9)
    fn.first_outside(x, np.zeros(3), np.ones(3), 1e-9)


def _segments():
    """Empty segment arrays and a one-bucket grid of them (kernel bucket_segments)."""
    seg_x, seg_lo = np.zeros((0, 4, 3)), np.zeros((0, 3))
    seg_move = np.empty(0)
    surface_contact.segment_moves(seg_x, seg_x.copy(), seg_move)
    lo, dims = np.zeros(3), np.ones(3, np.int64)
    start, items = surface_contact.bucket_segments(seg_lo, seg_lo.copy(), lo, 1.0, dims)
    surface_contact.box_bounds(seg_lo, seg_lo.copy(), lo.copy(), lo.copy())
    boxes, i0 = np.empty((1, 2, 3)), np.zeros(0, np.int64)
    surface_contact.body_box_bounds(seg_lo, seg_lo.copy(), i0, boxes)
    surface_contact.mark_rows_meeting(seg_lo, seg_lo.copy(), i0, 0, boxes[0],
                                      np.zeros(0, np.bool_))
    f2, i0 = np.zeros((0, 3)), np.zeros(0, np.int64)
    surface_contact.gather_segments(f2, f2.copy(), f2.copy(), np.zeros((0, 4), np.int64),
                                    seg_x.copy(), seg_x.copy(), seg_x.copy())
    surface_contact.point_moves(f2, f2.copy(), i0, np.zeros(0))
    node_contact.segment_boxes(seg_x, np.zeros(0), seg_lo.copy(), seg_lo.copy())
    return seg_x, seg_move, lo, dims, start, items


def warm_up_surface(grid=None):
    """The particle-to-surface contact kernels (ICFEMP, pmpm.solver.surface_contact);
    ``grid`` = (pts, geo, block, nodal, gnew, affine): also its grid side's."""
    seg_x, seg_move, lo, dims, start, items = _segments()
    i0, f1, f2 = np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3))
    touches, friction = np.zeros((1, 1), np.bool_), np.zeros((1, 1))
    surface_contact.find_pairs(f2, f2.copy(), i0, f1, f1.copy(), seg_x, seg_x.copy(),
                               seg_move, i0.copy(), i0.copy(), touches, lo, 1.0, dims,
                               start, items, i0.copy(), np.zeros((0, 6)))
    surface_contact.pair_impulses(i0, i0.copy(), np.zeros((0, 6)), f1, f2, i0.copy(),
                                  seg_x, np.zeros((0, 4)), i0.copy(), friction, f2.copy())
    if grid is not None:
        warm_up_surface_grid(*grid)


def warm_up_surface_grid(pts, geo, block, nodal, gnew, affine):
    """The particle side of ICFEMP on its body's grid (issue 24 Sec. 4), with the arrays'
    layouts the solver passes (column views of ``gnew`` and of the shares)."""
    x, body, level = pts.x, pts.body, pts.level
    i0, f1, f2 = np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3))
    n = len(gnew)
    field, dv = np.zeros((n, 1)), np.zeros((n, 3))
    surface_contact.gather_from_nodes(x, i0, body, geo, gnew[:, :3], f2.copy())
    surface_contact.gather_from_nodes(x, i0, body, geo, dv, f2.copy())
    surface_contact.surface_nodes(x, i0, body, f2.copy(), geo, i0.copy(), i0.copy(),
                                  f1.copy())
    # a rank whose block is empty (or one node) passes a contiguous column view
    for node_v in (gnew[:, :3], np.zeros((0, 3))):
        surface_contact.node_pair_impulses(i0, i0.copy(), f1, f1.copy(), field[:, 0],
                                           node_v, i0.copy(), np.zeros((0, 6)),
                                           np.zeros((0, 4, 3)), np.zeros((0, 4)),
                                           f1.copy(), f2.copy())
    surface_contact.nodal_velocity_changes(nodal, dv.copy(), gnew, block.faces,
                                           block.friction, dv)
    rigid = np.zeros(1, np.bool_)
    near = np.zeros(n, np.bool_)
    surface_contact.take_velocity_changes(x.copy(), x.copy(), pts.v.copy(), body, level,
                                          rigid, 0, geo, dv, near, 1e-3, None)
    if affine is not None:
        surface_contact.take_velocity_changes(x.copy(), x.copy(), pts.v.copy(), body,
                                              level, rigid, 0, geo, dv, near, 1e-3,
                                              affine.copy())


def warm_up_node_contact():
    """The FEM node-to-surface contact kernels (pmpm.solver.node_contact)."""
    seg_x, seg_move, lo, dims, start, items = _segments()
    i0, f1, f2 = np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3))
    node_contact.segment_boxes(seg_x, f1, f2, f2.copy())
    touches, friction = np.zeros((1, 1), np.bool_), np.zeros((1, 1))
    node_contact.find_node_pairs(f2, f2.copy(), f1, i0, seg_x, seg_x.copy(), seg_move,
                                 i0.copy(), i0.copy(), f1.copy(), touches, 0.0, lo, 1.0,
                                 dims, start, items, i0.copy(), np.zeros((0, 6)))
    node_contact.node_pair_impulses(i0, i0.copy(), np.zeros((0, 6)), f1, f2, i0.copy(),
                                    seg_x, np.zeros((0, 4)), i0.copy(), friction, 1e-3,
                                    f2.copy(), f1.copy())


def warm_up_fem_grid(pts, geo, block, force, slots, view, exact=False):
    """The grid coupling's kernels (CFEMP, pmpm.solver.fem_grid) on the warm-up's point,
    grid and (empty) contact slots and view; with ``exact`` also the layer-ordered force
    scatter (``grid.exact_sums``)."""
    fem_grid.node_forces_to_grid(pts, geo, force, np.zeros((1, 3)), view.slot_of,
                                 view.cforce, 0)
    if exact:
        halo, order = HALO[len(geo.shape)], np.zeros(1, np.int64)
        fem_grid.node_forces_to_grid(pts, geo, force, np.zeros((1, 3)), view.slot_of,
                                     view.cforce, 0, _layers(order, 3, halo, 9),
                                     _layers(order, view.cforce.shape[1] * 3, halo, 0))
    n_slots, nb = slots.cnodal.shape[:2]
    dacc = np.zeros((n_slots, nb, 3))
    rigid = np.zeros(nb, np.bool_)
    fem_grid.contact_accelerations(slots, rigid, 1e-12, block, dacc)
    fem_grid.contact_velocity_changes(pts, geo, view.slot_of, dacc, 1e-3, rigid,
                                      np.zeros((1, 3)), 0)
    fem_grid.near_coupled_nodes(np.zeros((1, 3)), np.zeros(1, np.int32), np.ones(nb, np.bool_),
                                np.zeros((nb, nb), np.bool_), np.zeros((nb, 2, 3)),
                                np.zeros(1, np.bool_))


def _layers(order, width, halo, per_plane):
    """A LayerSums record over the warm-up block's 3 node planes of ``per_plane`` rows
    (9 nodes, or no contact slots), as pmpm.kernels.warmup.warm_up_layers."""
    return LayerSums(order, 0, np.arange(4, dtype=np.int64) * per_plane, halo,
                     np.zeros((max(3 * per_plane, 1), width)),
                     np.zeros((1, per_plane, width)))


def sums_variants(exact):
    """The kinds of the force log's sums: plain (False), and with ``exact`` (grid.
    exact_sums) exact accumulators (True)."""
    return (False, True) if exact else (False,)


def sums_like(shape, exact):
    """Zero sums of ``shape``: floats, or an exact accumulator (pmpm.kernels.exact_sum)."""
    return exact_sum.zeros(shape) if exact else np.zeros(shape)


def warm_up_forces(block, pairs, gvel, gnew, slots=None, free_rigid=False, exact=False):
    """The force log's kernels (pmpm.solver.forces): the grid faces' impulses, the
    surface pairs', and with grid contact's ``slots`` its pairs' (``free_rigid``: also
    the free rigid particle bodies' partners, pmpm.solver.rigid_particles); with
    ``exact`` also into exact accumulators."""
    for exact_sums in sums_variants(exact):
        warm_up_force_sums(block, pairs, gvel, gnew, slots, free_rigid and exact_sums == exact,
                           exact_sums)


def warm_up_force_sums(block, pairs, gvel, gnew, slots, free_rigid, exact_sums):
    """:func:`warm_up_forces` into plain or (``exact_sums``) exact sums."""
    n = len(block.faces)
    nodes, face_of = np.empty(n, np.int64), np.empty(n, np.int64)
    counted = np.ones(1, np.bool_)
    count = forces.face_zone(block.faces, pairs, counted, n, nodes, face_of)
    raw = np.empty((count, forces.RAW_WIDTH))
    forces.keep_rows(nodes, count, gnew, 0, raw)
    face = sums_like((6, forces.FACE_WIDTH), exact_sums)
    slave = np.zeros(n, np.int8)
    forces.face_impulses(nodes, face_of, count, raw, gvel, gnew, block, 0.0, 1e-3, 1e-12,
                         slave, face)
    pair = sums_like((1, 1, forces.PAIR_WIDTH), exact_sums)
    i0, f2 = np.zeros(0, np.int64), np.zeros((0, 3))
    forces.pair_impulses(i0, i0.copy(), f2, f2.copy(), np.zeros(0), pair)
    if slots is None:
        return
    nb = slots.cnodal.shape[1]
    real_mass, share, rigid = np.zeros((0, nb)), np.ones(nb), np.zeros(nb, np.bool_)
    forces.contact_impulses(slots, real_mass, share, rigid, block.faces, counted, n,
                            1e-3, 1e-12, slave, sums_like((nb, nb, forces.PAIR_WIDTH), exact_sums))
    if free_rigid:
        forces.rigid_partner_impulses(slots, real_mass, share, rigid, rigid.copy(),
                                      block.faces, counted, n, 1e-3,
                                      sums_like((nb, 3), exact_sums))


def warm_up_couplings(pts, geo, block, pairs, mat, bodies, grids, contact_state, kinds,
                      affine=None):
    """The kernels of what ``kinds`` names (the keys of :func:`pmpm.kernels.warmup.
    kernels_of` that are true: ``fem``, ``surface``, ``node_contact``, ``fem_grid``,
    ``forces``, ``free_rigid``); ``grids`` = (nodal, force, gvel, gnew) and
    ``contact_state`` = (slots, view) of grid contact, or None without it; ``affine``
    the APIC matrices when the transfers are APIC's."""
    nodal, force, gvel, gnew = grids
    slots, view = contact_state or (None, None)
    if kinds.get("fem"):
        warm_up_elements(mat, bodies, kinds.get("exact", False))
    if kinds.get("surface"):
        warm_up_surface((pts, geo, block, nodal, gnew, affine))
    if kinds.get("node_contact"):
        warm_up_node_contact()
    if kinds.get("fem_grid") and slots is not None:
        warm_up_fem_grid(pts, geo, block, force, slots, view, kinds.get("exact", False))
    if kinds.get("forces"):
        warm_up_forces(block, pairs, gvel, gnew, slots, kinds.get("free_rigid", False),
                       kinds.get("exact", False))

