"""The FE nodes' side of the step in one pass each (Numba): the central-difference
velocity update with the constraints and the grid box faces' conditions, and the
reactions those gave the nodes (issue 25: done with whole-array NumPy expressions they
took 0.4 us per element-step on the copper block, more than half the element loop).

Faces come as parallel arrays, one entry per constrained face of the grid box
(pmpm.solver.fem_bodies.constrained_faces): ``axis`` (int64), ``side`` (-1.0 the min
face, +1.0 the max face), ``plane`` and ``fixed`` (bool; else slip or symmetry). Every
node is independent of the others, so a node's faces are applied in their order, as the
whole-array expressions of before did, and each sum takes the nodes in index order:
the answers are those of before to the bit.

Nothing here reads configuration or calls MPI.
"""
import numpy as np
from numba import njit

from ..kernels.exact_sum import put2
from ..materials.tensors import fdiv


@njit(cache=True, inline="always")
def hold_node(x, v, n, axis, side, plane, fixed, dt, tol):
    """The faces' conditions on node ``n``: on a face (within ``tol`` of its plane) a
    fixed face zeroes the velocity, a slip or symmetry face its normal component; beyond
    a face no component may point further out; and (``dt`` > 0) a node that would cross a
    face in this step lands on it."""
    for f in range(axis.shape[0]):
        d, s = axis[f], side[f]
        gap = s * (plane[f] - x[n, d])             # > 0 inside the box
        at = gap <= tol
        if at:
            if fixed[f]:
                v[n, 0] = 0.0
                v[n, 1] = 0.0
                v[n, 2] = 0.0
            elif gap >= -tol or s * v[n, d] > 0:
                v[n, d] = 0.0
        elif dt > 0.0 and s * v[n, d] * dt > gap:
            v[n, d] = fdiv(s * gap, dt)


@njit(cache=True)
def hold_at_faces(x, v, movable, axis, side, plane, fixed, dt, tol):
    """:func:`hold_node` on every ``movable`` node (``dt`` <= 0: no landing on faces)."""
    for n in range(x.shape[0]):
        if movable[n]:
            hold_node(x, v, n, axis, side, plane, fixed, dt, tol)


@njit(cache=True, inline="always")
def face_of_component(x, n, i, imp, axis, side, plane, fixed, tol):
    """The constrained box face (2 axis + upper, -1: none) that pushed component ``i`` of
    node ``n`` with the impulse ``imp``: the face of that axis the impulse points away
    from (the last such face), else (the tangential hold of a fixed face) the first fixed
    face of another axis the node lies on."""
    out = -1
    for f in range(axis.shape[0]):
        if axis[f] == i and side[f] * imp < 0.0:
            out = 2 * i + (1 if side[f] > 0 else 0)
    if out < 0:
        for f in range(axis.shape[0]):
            d = axis[f]
            if out < 0 and fixed[f] and d != i and side[f] * (plane[f] - x[n, d]) <= tol:
                out = 2 * d + (1 if side[f] > 0 else 0)
    return out                  # one exit: an early return inside the loops made Numba
    #                             keep the arrays' reference counting in the caller's loop


@njit(cache=True)
def advance_and_hold(x, v, force, mass, fixed_dof, movable, axis, side, plane, fixed, dt,
                     tol, log, counted, node_body, support, face):
    """v <- v + dt f / m with the constraints (``fixed_dof`` (n, 3): components held at
    zero), then the faces' conditions on the ``movable`` nodes (:func:`hold_node`);
    with ``log`` (a force log), the ``counted`` nodes add their reaction impulse
    m (v - v_before) - dt f to ``support[node_body]`` (a node with a held component) or,
    per component, to ``face[face number, component]`` of the face that pushed it. A node
    that nothing held adds nothing (m (v - v_before) - dt f is round-off there)."""
    for n in range(v.shape[0]):
        b0, b1, b2 = v[n, 0], v[n, 1], v[n, 2]
        inv = dt * fdiv(1.0, mass[n])
        for i in range(3):
            v[n, i] = 0.0 if fixed_dof[n, i] else v[n, i] + force[n, i] * inv
        a0, a1, a2 = v[n, 0], v[n, 1], v[n, 2]
        if movable[n]:
            hold_node(x, v, n, axis, side, plane, fixed, dt, tol)
        if not (log and counted[n]):
            continue
        if (a0 == v[n, 0] and a1 == v[n, 1] and a2 == v[n, 2] and not (
                fixed_dof[n, 0] or fixed_dof[n, 1] or fixed_dof[n, 2])):
            continue           # held by nothing: its "reaction" would be round-off
        m = mass[n]
        i0 = m * (v[n, 0] - b0) - dt * force[n, 0]
        i1 = m * (v[n, 1] - b1) - dt * force[n, 1]
        i2 = m * (v[n, 2] - b2) - dt * force[n, 2]
        if fixed_dof[n, 0] or fixed_dof[n, 1] or fixed_dof[n, 2]:
            bb = node_body[n]
            put2(support, bb, 0, i0)
            put2(support, bb, 1, i1)
            put2(support, bb, 2, i2)
            continue
        for i in range(3):
            imp = i0 if i == 0 else (i1 if i == 1 else i2)
            f = face_of_component(x, n, i, imp, axis, side, plane, fixed, tol)
            if f >= 0:
                put2(face, f, i, imp)


@njit(cache=True)
def first_outside(x, lo, hi, tol):
    """The first node (-1: none) with a coordinate below ``lo - tol`` or above
    ``hi + tol``."""
    for n in range(x.shape[0]):
        for d in range(3):
            if x[n, d] < lo[d] - tol or x[n, d] > hi[d] + tol:
                return n
    return -1
