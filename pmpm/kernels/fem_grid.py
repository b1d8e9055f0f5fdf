"""Grid coupling of FE nodes to particle bodies (CFEMP, seed 004 Sec. 2.4): the node
loops that the particle kernels do not already do.

The FE nodes of a grid-coupled FEM body act as points of their body on the coarse grid:
their mass, momentum, mass gradient and extents go through the particle kernels
(``pmpm.kernels.mpm.particles_to_grid``, ``pmpm.kernels.contact``) with a ``PointState``
built from the nodes. What differs from a particle: a node's force is the force the
element mesh put on it (no stress of its own), and the contact correction returns to it
as a velocity increment (FLIP), dv_K = sum_I N_IK dt f_I^c / m_I (the seed's Eqs. 28-32
through pmpm's contact kernels), never as the grid's velocity. Since
sum_K N_IK m_K = m_I for the body, the increments carry exactly the momentum the
contact forces put into the body's field.
"""
import numpy as np
from numba import njit

from .boundary import constrain_coded
from .layered import NO_LAYER, layer_plane, leave_layer, point_at, unpack
from .shape import MAX_NODES, weights


@njit(cache=True)
def node_forces_to_grid(pts, geo, force, node_force, slot_of, cforce, want, layers=None,
                        clayers=None):
    """Scatter the FE nodes' forces ``node_force`` (n, 3) to the shared nodal ``force``
    and, at contact nodes (``slot_of`` >= 0), to their body's ``cforce``: the body's
    trial momentum at a grid node is then sum_K N_IK (m_K v_K + dt f_K) (Eq. 26). With
    ``layers`` (a LayerSums for ``force``) and ``clayers`` (one over the contact slots,
    rows (n_slots, n_bodies * 3)) the sums are layer-ordered (``pmpm.kernels.layered``)."""
    x, _, _, body, level = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)
    nodes, axes = np.empty(MAX_NODES, np.int64), np.empty((9, 3))
    w = np.empty(MAX_NODES)
    order, count, axis, starts, halo, scratch, kept = unpack(layers, x.shape[0])
    _, _, _, cstarts, _, cscratch, ckept = unpack(clayers, 0)
    cflat = cforce.reshape((cforce.shape[0], cforce.shape[1] * 3))
    acc, cacc, current, shift, cshift = force, cforce, NO_LAYER, 0, 0
    if layers is not None:
        acc = scratch
    if clayers is not None:
        cacc = cscratch.reshape((cscratch.shape[0], cforce.shape[1], 3))
    for i in range(count):
        p = point_at(layers, order, i)
        if level[p] != want:
            continue
        if layers is not None and clayers is not None:
            layer = layer_plane(x, p, origin, inv_h, lo, axis)
            if layer != current:
                leave_layer(layer, current, force, acc, starts, halo, kept)
                leave_layer(layer, current, cflat, cscratch, cstarts, halo, ckept)
                current, shift, cshift = layer, starts[layer - halo], cstarts[layer - halo]
        b = body[p]
        reach = weights(x, p, origin, inv_h, lo, strides, shape, half_width[b], axes,
                        nodes, w)
        for k in range(reach):
            n, wk = nodes[k], w[k]
            s = slot_of[n]
            for d in range(3):
                f = wk * node_force[p, d]
                acc[n - shift, d] += f
                if s >= 0:
                    cacc[s - cshift, b, d] += f
    if layers is not None and clayers is not None:
        leave_layer(NO_LAYER, current, force, acc, starts, halo, kept)
        leave_layer(NO_LAYER, current, cflat, cscratch, cstarts, halo, ckept)


@njit(cache=True)
def contact_accelerations(slots, rigid, m_tiny, block, dacc):
    """Per contact slot and body the acceleration the contact force of
    :func:`pmpm.kernels.contact.contact_end` added, f^c / m (within the node's face
    conditions): the end acceleration ``cnew[:, :, 3:]`` less the body's own, cforce / m
    constrained as contact_end constrains it (the constraint is a linear projection, so
    the difference is the constrained contact part). Zero where the body is absent or
    rigid (contact_end leaves those at the shared field)."""
    cnodal, slot_nodes, _, _, cforce, cnew = slots
    faces = block.faces
    own = np.empty(3)
    for s in range(slot_nodes.shape[0]):
        code = faces[slot_nodes[s]]
        for b in range(cnodal.shape[1]):
            m = cnodal[s, b, 0]
            if m <= m_tiny or rigid[b]:
                dacc[s, b, 0] = dacc[s, b, 1] = dacc[s, b, 2] = 0.0
                continue
            for d in range(3):
                own[d] = cforce[s, b, d] / m
            constrain_coded(own, code)
            for d in range(3):
                dacc[s, b, d] = cnew[s, b, 3 + d] - own[d]


@njit(cache=True)
def contact_velocity_changes(pts, geo, slot_of, dacc, dt, rigid, dv, want):
    """dv[p] = dt sum_I N_Ip dacc[slot(I), body(p)] over the contact nodes the FE node p
    reaches (FLIP: the node keeps its own velocity and takes the contact's change)."""
    x, _, _, body, level = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)
    nodes, axes = np.empty(MAX_NODES, np.int64), np.empty((9, 3))
    w = np.empty(MAX_NODES)
    for p in range(x.shape[0]):
        dv[p, 0] = dv[p, 1] = dv[p, 2] = 0.0
        b = body[p]
        if level[p] != want or rigid[b]:
            continue
        reach = weights(x, p, origin, inv_h, lo, strides, shape, half_width[b], axes,
                        nodes, w)
        for k in range(reach):
            s = slot_of[nodes[k]]
            if s < 0:
                continue
            for d in range(3):
                dv[p, d] += dt * w[k] * dacc[s, b, d]


@njit(cache=True)
def near_coupled_nodes(x, node_body, coupled, meets, reach, near):
    """near[k] = whether FE node k's body is grid-coupled (``coupled[b]``) and the node
    lies in the box ``reach[o]`` ((n_bodies, 2, 3): low and high corners) of a body o
    that its body meets on the grid (``meets[b, o]``); one pass over the nodes."""
    for k in range(x.shape[0]):
        b = node_body[k]
        inside = False
        if coupled[b]:
            for o in range(meets.shape[1]):
                if not meets[b, o]:
                    continue
                inside = True
                for d in range(3):
                    if x[k, d] < reach[o, 0, d] or x[k, d] > reach[o, 1, d]:
                        inside = False
                        break
                if inside:
                    break
        near[k] = inside
