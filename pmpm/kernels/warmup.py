"""Compile (or load from Numba's cache) every kernel of the step on a one-particle
problem, so that compile time is measured apart from run time."""
import time

import numpy as np

from ..materials import layout
from . import contact, mpm, tied
from .cache import refresh_inlined_caches


def warm_up():
    """Return the seconds spent compiling or loading the kernels."""
    started = time.perf_counter()
    refresh_inlined_caches()
    origin, inv_h = np.zeros(3), 1.0
    lo, strides, shape = np.zeros(3, np.int64), np.array([4, 2, 1], np.int64), np.full(3, 2, np.int64)
    x = np.full((1, 3), 0.5)
    v = np.zeros((1, 3))
    ones = np.ones(1)
    body = np.zeros(1, np.int32)
    rigid = np.zeros(1, np.bool_)
    nodal = np.zeros((8, mpm.NODAL_COMPONENTS))
    gvel, force, gnew = np.zeros((8, 3)), np.zeros((8, 3)), np.zeros((8, 6))
    prm = np.zeros((1, layout.N_SLOTS))
    prm[0, [layout.RHO0, layout.E, layout.G, layout.K]] = 1.0
    bc, n_cells = np.zeros(6, np.int64), np.ones(3, np.int64)
    level = np.zeros(1, np.int32)
    mpm.particles_to_grid(x, v, ones, body, rigid, origin, inv_h, lo, strides, nodal, level, 0)
    mpm.nodal_velocities(nodal, shape, lo, strides, n_cells, bc, 0.0, gvel)
    mask, slot_of = np.zeros(8, np.int64), np.zeros(8, np.int64)
    contact.body_masks(x, body, origin, inv_h, lo, strides, mask, level, 0)
    slot_nodes = contact.number_contact_nodes(mask, slot_of)
    cnodal = np.zeros((0, 1, contact.CNODAL))
    cvel, cforce, cnew = np.zeros((0, 1, 3)), np.zeros((0, 1, 3)), np.zeros((0, 1, 6))
    contact.contact_particles_to_grid(x, v, ones, body, origin, inv_h, lo, strides, slot_of,
                                      cnodal, level, 0)
    contact.contact_start(cnodal, slot_nodes, gvel, np.zeros((1, 1), np.int64),
                          np.full((1, 1), np.inf), rigid, 2, 0.0,
                          shape, lo, strides, n_cells, bc, cvel, cvel)
    mpm.stress_and_forces(x, v, ones.copy(), ones.copy(), np.zeros((1, 6)),
                          np.eye(3).reshape(1, 9).copy(), np.zeros(1), np.zeros(1), np.zeros(1),
                          np.zeros(1), body, np.full(1, -1, np.int32), np.zeros(1),
                          np.zeros(1, np.int64), prm, rigid, 1e-3, 1.0, np.zeros(3),
                          np.zeros((1, 3)), origin, inv_h, lo, strides, gvel, force,
                          True, slot_of, cvel, cforce, level, 0)
    mpm.integrate_nodes(nodal, force, gvel, 1e-3, shape, lo, strides, n_cells, bc, 0.0, gnew)
    contact.contact_end(cnodal, cvel, cvel, cforce, slot_nodes, gvel, gnew, np.zeros((1, 1)),
                        np.full((1, 1), np.inf), rigid, True, 1e-3, 0.0, shape, lo, strides,
                        n_cells, bc, cnew)
    mpm.grid_to_particles(x, v, body, rigid, 1e-3, origin, inv_h, lo, strides, gnew,
                          True, slot_of, cnew, level, 0)
    mpm.cell_keys(x, origin, inv_h, n_cells)
    owner, ratios = np.zeros(1, np.int64), np.ones(1, np.int64)
    mpm.classify_particles(x, origin, inv_h, n_cells, 0, np.array([0, 1], np.int64), owner)
    mpm.level_spans(x, level, origin, inv_h, n_cells, ratios, np.ones(1), np.zeros(6))
    warm_up_ties(x, level, origin, inv_h, lo, strides, shape, mask, nodal)
    return time.perf_counter() - started


def warm_up_ties(x, level, origin, inv_h, lo, strides, shape, mask, nodal):
    """The tied-interface kernels (pmpm.kernels.tied)."""
    tied.particle_levels(x, origin, inv_h, np.zeros((1, 3), np.int64),
                         np.ones((1, 3), np.int64), level)
    level[:] = 0
    tied.mark_occupied(x, level, origin, inv_h, lo, strides, mask)
    slaves, masters, weights = np.zeros(8, np.int64), np.zeros((8, 8), np.int64), np.zeros((8, 8))
    count = tied.find_ties(shape, lo, strides, lo, lo + 1, 2, shape, lo, strides, mask,
                           slaves, masters, weights)
    tied.slaves_to_masters(slaves, masters, weights, count, nodal, nodal)
    tied.masters_to_slaves(slaves, masters, weights, count, nodal, nodal)
    tied.clear_slave_slots(slaves, count, mask)
