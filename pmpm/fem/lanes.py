"""The reduced hexahedron on blocks of LANES elements at once (Numba, issue 25), so that
the compiler can run each stage's arithmetic on LANES elements per SIMD instruction.

Every element's arithmetic is the scalar path's (:mod:`pmpm.fem.hexahedron`,
:mod:`pmpm.fem.stability`, :mod:`pmpm.fem.elements`) operation for operation, in the
same order: only the lanes run side by side, so the answers are bit-identical. What
decides whether LLVM vectorises a loop over the lanes: the block's arrays are flat, with
the lane index last and every other offset a compile-time constant (``row * LANES + l``,
the rows literal arguments of inlined helpers), and the lane count a constant; with 2-D
or 3-D scratch arrays (run-time strides) it would need more run-time alias checks than
it allows and leave the loop scalar. Calls that do not vectorise (``np.cbrt``, the
material update) run in loops of their own.

Layout of a block's scratch arrays (``row * LANES + lane``): node coordinates, velocities,
mean gradients and element forces ``3 * node + component``; hourglass shapes
``8 * mode + node``; velocity gradient ``3 * i + j``; stress ``0..5`` (Voigt);
generalized hourglass forces and hourglass rates ``3 * mode + component``.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..materials.layout import G, Q_LINEAR, Q_QUADRATIC
from ..materials.tensors import fdiv
from .hexahedron import HOURGLASS
from .stability import STIFFNESS, gram_row_bound

#: elements per block: 16 doubles are two AVX-512 (four AVX2) registers; with 8 LLVM
#: unrolls the lane loops completely and leaves them scalar
LANES = 16

#: A block's scratch arrays (see the module's docstring for the layout).
Block = namedtuple("Block", "x v b gamma fe lg sigma resist hg_rate volume inv_volume "
                            "length rho c root root2 own work gain ok")


@njit(cache=True)
def new_block():
    """Scratch arrays for one block of LANES elements (allocated once per call of the
    element loop)."""
    n = LANES
    return Block(np.empty(24 * n), np.empty(24 * n), np.empty(24 * n), np.empty(32 * n),
                 np.empty(24 * n), np.empty(9 * n), np.empty(6 * n), np.empty(12 * n),
                 np.empty(12 * n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
                 np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n),
                 np.empty(n), np.empty(n, np.bool_))


@njit(cache=True, inline="always")
def gather(x, v, hexes, e0, X, V):
    """The block's node coordinates and velocities, element e0 + l in lane l."""
    for l in range(LANES):
        for k in range(8):
            n = hexes[e0 + l, k]
            for i in range(3):
                X[(3 * k + i) * LANES + l] = x[n, i]
                V[(3 * k + i) * LANES + l] = v[n, i]


@njit(cache=True, inline="always")
def _component(X, l, cy, cz, p1, p2, p3, p4, p5, p7):
    """pmpm.fem.hexahedron._b_component in lane l (p1.. the permutation's entries)."""
    y1, y2 = X[(3 * p1 + cy) * LANES + l], X[(3 * p2 + cy) * LANES + l]
    y3, y4 = X[(3 * p3 + cy) * LANES + l], X[(3 * p4 + cy) * LANES + l]
    y5, y7 = X[(3 * p5 + cy) * LANES + l], X[(3 * p7 + cy) * LANES + l]
    z1, z2 = X[(3 * p1 + cz) * LANES + l], X[(3 * p2 + cz) * LANES + l]
    z3, z4 = X[(3 * p3 + cz) * LANES + l], X[(3 * p4 + cz) * LANES + l]
    z5, z7 = X[(3 * p5 + cz) * LANES + l], X[(3 * p7 + cz) * LANES + l]
    return (y1 * ((z5 - z2) - (z3 - z4)) + y2 * (z1 - z3)
            + y3 * ((z2 - z7) - (z4 - z1)) + y4 * ((z7 - z5) - (z1 - z3))
            + y5 * (z4 - z1) + y7 * (z3 - z4)) / 12.0


@njit(cache=True, inline="always")
def _node_gradient(X, B, l, node, p1, p2, p3, p4, p5, p7):
    """b of ``node`` in lane l (pmpm.fem.hexahedron.PERMUTATION's row of the node);
    returns its term x_I . b_I of 3 V."""
    b0 = _component(X, l, 1, 2, p1, p2, p3, p4, p5, p7)
    b1 = _component(X, l, 2, 0, p1, p2, p3, p4, p5, p7)
    b2 = _component(X, l, 0, 1, p1, p2, p3, p4, p5, p7)
    B[(3 * node) * LANES + l] = b0
    B[(3 * node + 1) * LANES + l] = b1
    B[(3 * node + 2) * LANES + l] = b2
    return X[(3 * node) * LANES + l] * b0 + X[(3 * node + 1) * LANES + l] * b1 \
        + X[(3 * node + 2) * LANES + l] * b2


@njit(cache=True, inline="always")
def mean_gradients(X, B, volume):
    """pmpm.fem.hexahedron.mean_gradient in every lane (the permutations written out)."""
    for l in range(LANES):
        v = 0.0
        v += _node_gradient(X, B, l, 0, 1, 2, 3, 4, 5, 7)
        v += _node_gradient(X, B, l, 1, 2, 3, 0, 5, 6, 4)
        v += _node_gradient(X, B, l, 2, 3, 0, 1, 6, 7, 5)
        v += _node_gradient(X, B, l, 3, 0, 1, 2, 7, 4, 6)
        v += _node_gradient(X, B, l, 4, 7, 6, 5, 0, 3, 1)
        v += _node_gradient(X, B, l, 5, 4, 7, 6, 1, 0, 2)
        v += _node_gradient(X, B, l, 6, 5, 4, 7, 2, 1, 3)
        v += _node_gradient(X, B, l, 7, 6, 5, 4, 3, 2, 0)
        volume[l] = v / 3.0


@njit(cache=True, inline="always")
def _face_norm2(X, l, a, b, c, d):
    """Squared norm of the cross product of face (a, b, c, d)'s diagonals, lane l."""
    p0 = X[(3 * c) * LANES + l] - X[(3 * a) * LANES + l]
    p1 = X[(3 * c + 1) * LANES + l] - X[(3 * a + 1) * LANES + l]
    p2 = X[(3 * c + 2) * LANES + l] - X[(3 * a + 2) * LANES + l]
    q0 = X[(3 * d) * LANES + l] - X[(3 * b) * LANES + l]
    q1 = X[(3 * d + 1) * LANES + l] - X[(3 * b + 1) * LANES + l]
    q2 = X[(3 * d + 2) * LANES + l] - X[(3 * b + 2) * LANES + l]
    n0, n1, n2 = p1 * q2 - p2 * q1, p2 * q0 - p0 * q2, p0 * q1 - p1 * q0
    return n0 * n0 + n1 * n1 + n2 * n2


@njit(cache=True, inline="always")
def lengths(X, volume, inv_volume, length):
    """1 / V and the bulk viscosity's length V / (largest face area) in every lane
    (pmpm.fem.hexahedron.largest_face_area's faces, FACES, written out)."""
    for l in range(LANES):
        largest = 0.0
        largest = max(largest, _face_norm2(X, l, 0, 3, 2, 1))
        largest = max(largest, _face_norm2(X, l, 4, 5, 6, 7))
        largest = max(largest, _face_norm2(X, l, 0, 1, 5, 4))
        largest = max(largest, _face_norm2(X, l, 1, 2, 6, 5))
        largest = max(largest, _face_norm2(X, l, 2, 3, 7, 6))
        largest = max(largest, _face_norm2(X, l, 3, 0, 4, 7))
        inv_volume[l] = fdiv(1.0, volume[l])
        length[l] = volume[l] * fdiv(1.0, 0.5 * np.sqrt(largest))


@njit(cache=True, inline="always")
def velocity_gradients(V, B, inv_volume, lg):
    """L_ij = (sum_I v_Ii b_Ij) / V in every lane."""
    for l in range(LANES):
        for i in range(3):
            for j in range(3):
                s = 0.0
                for k in range(8):
                    s += V[(3 * k + i) * LANES + l] * B[(3 * k + j) * LANES + l]
                lg[(3 * i + j) * LANES + l] = s * inv_volume[l]


@njit(cache=True, inline="always")
def stress_forces(sigma, B, fe):
    """fe_I = -(sigma - q I) b_I in every lane (``sigma`` holds sigma - q I)."""
    for l in range(LANES):
        sxx, syy, szz = sigma[l], sigma[LANES + l], sigma[2 * LANES + l]
        sxy, syz, szx = sigma[3 * LANES + l], sigma[4 * LANES + l], sigma[5 * LANES + l]
        for k in range(8):
            bx = B[(3 * k) * LANES + l]
            by = B[(3 * k + 1) * LANES + l]
            bz = B[(3 * k + 2) * LANES + l]
            fe[(3 * k) * LANES + l] = -(sxx * bx + sxy * by + szx * bz)
            fe[(3 * k + 1) * LANES + l] = -(sxy * bx + syy * by + syz * bz)
            fe[(3 * k + 2) * LANES + l] = -(szx * bx + syz * by + szz * bz)


@njit(cache=True, inline="always")
def _mode_shape(X, B, inv_volume, gamma, a, l):
    """pmpm.fem.hexahedron.hourglass_shapes for mode a, lane l."""
    hx = hy = hz = 0.0
    for node in range(8):
        h = HOURGLASS[a, node]
        hx += h * X[(3 * node) * LANES + l]
        hy += h * X[(3 * node + 1) * LANES + l]
        hz += h * X[(3 * node + 2) * LANES + l]
    for node in range(8):
        gamma[(8 * a + node) * LANES + l] = HOURGLASS[a, node] - (
            hx * B[(3 * node) * LANES + l] + hy * B[(3 * node + 1) * LANES + l]
            + hz * B[(3 * node + 2) * LANES + l]) * inv_volume[l]


@njit(cache=True, inline="always")
def hourglass_shapes(X, B, inv_volume, gamma):
    """The Flanagan-Belytschko hourglass shapes in every lane."""
    for l in range(LANES):
        _mode_shape(X, B, inv_volume, gamma, 0, l)
        _mode_shape(X, B, inv_volume, gamma, 1, l)
        _mode_shape(X, B, inv_volume, gamma, 2, l)
        _mode_shape(X, B, inv_volume, gamma, 3, l)


@njit(cache=True, inline="always")
def _dot8(gamma, a, c, l):
    """gamma_a . gamma_c in lane l, summed over the nodes in order."""
    s = 0.0
    for k in range(8):
        s += gamma[(8 * a + k) * LANES + l] * gamma[(8 * c + k) * LANES + l]
    return s


@njit(cache=True, inline="always")
def _gram_bound(gamma, l):
    """pmpm.fem.stability.hourglass_gram_bound in lane l."""
    g00, g01, g02, g03 = _dot8(gamma, 0, 0, l), _dot8(gamma, 0, 1, l), \
        _dot8(gamma, 0, 2, l), _dot8(gamma, 0, 3, l)
    g11, g12, g13 = _dot8(gamma, 1, 1, l), _dot8(gamma, 1, 2, l), _dot8(gamma, 1, 3, l)
    g22, g23, g33 = _dot8(gamma, 2, 2, l), _dot8(gamma, 2, 3, l), _dot8(gamma, 3, 3, l)
    return gram_row_bound(g00, g01, g02, g03, g11, g12, g13, g22, g23, g33)


@njit(cache=True, inline="always")
def cube_roots(kind, volume, root, root2):
    """cbrt(V) and cbrt(V^2) of every lane for the viscous hourglass form (a loop of its
    own: the library call does not vectorise)."""
    if kind == STIFFNESS:
        return
    for l in range(LANES):
        root[l] = np.cbrt(volume[l])
        root2[l] = np.cbrt(volume[l] * volume[l])


@njit(cache=True, inline="always")
def stable_rates(blk, prm, kind, hg_k):
    """pmpm.fem.stability.stable_rate in every lane, the reduced element's forms (VISCOUS,
    STIFFNESS), into ``blk.own``."""
    B, gamma, lg = blk.b, blk.gamma, blk.lg
    shear, q_lin, q_quad = prm[G], prm[Q_LINEAR], prm[Q_QUADRATIC]
    for l in range(LANES):
        xx = yy = zz = xy = yz = zx = 0.0
        for k in range(8):
            bx = B[(3 * k) * LANES + l]
            by = B[(3 * k + 1) * LANES + l]
            bz = B[(3 * k + 2) * LANES + l]
            xx += bx * bx
            yy += by * by
            zz += bz * bz
            xy += bx * by
            yz += by * bz
            zx += bz * bx
        beta = max(xx + abs(xy) + abs(zx), max(yy + abs(xy) + abs(yz),
                                               zz + abs(yz) + abs(zx)))
        s = xx + yy + zz
        g = _gram_bound(gamma, l)
        volume, length, rho, c = blk.volume[l], blk.length[l], blk.rho[l], blk.c[l]
        div = lg[l] + lg[4 * LANES + l] + lg[8 * LANES + l]
        inv_v2 = fdiv(1.0, volume * volume)
        lam = max(rho * c * c - 2.0 * shear, 0.0)
        omega2 = 8.0 * (lam * s + 2.0 * shear * beta) * inv_v2 * fdiv(1.0, rho)
        eta = 8.0 * length * (q_lin * c + q_quad * length * abs(div)) * s * inv_v2
        if kind == STIFFNESS:
            omega2 += 8.0 * hg_k * c * c * s * g * inv_v2 / 3.0
        else:
            eta += 2.0 * hg_k * c * g * fdiv(1.0, blk.root[l])
        blk.own[l] = 0.5 * (0.5 * eta + np.sqrt(omega2 + 0.25 * eta * eta))


@njit(cache=True, inline="always")
def rotate_resistances(resist, lg, dt):
    """pmpm.fem.elements.rotate_resistance in every lane."""
    for l in range(LANES):
        w01 = 0.5 * (lg[LANES + l] - lg[3 * LANES + l]) * dt
        w02 = 0.5 * (lg[2 * LANES + l] - lg[6 * LANES + l]) * dt
        w12 = 0.5 * (lg[5 * LANES + l] - lg[7 * LANES + l]) * dt
        for a in range(4):
            q0 = resist[(3 * a) * LANES + l]
            q1 = resist[(3 * a + 1) * LANES + l]
            q2 = resist[(3 * a + 2) * LANES + l]
            resist[(3 * a) * LANES + l] = q0 + w01 * q1 + w02 * q2
            resist[(3 * a + 1) * LANES + l] = q1 - w01 * q0 + w12 * q2
            resist[(3 * a + 2) * LANES + l] = q2 - w02 * q0 - w12 * q1


@njit(cache=True, inline="always")
def _rate(V, gamma, rates, a, i, l):
    """The hourglass rate q_ai = sum_I v_Ii gamma_aI in lane l."""
    r = 0.0
    for k in range(8):
        r += V[(3 * k + i) * LANES + l] * gamma[(8 * a + k) * LANES + l]
    rates[(3 * a + i) * LANES + l] = r


@njit(cache=True, inline="always")
def _rates(V, gamma, rates):
    """The hourglass rates in every lane (written out: a loop over the modes and
    components left LLVM's loops over the lanes scalar)."""
    for l in range(LANES):
        _rate(V, gamma, rates, 0, 0, l)
        _rate(V, gamma, rates, 0, 1, l)
        _rate(V, gamma, rates, 0, 2, l)
        _rate(V, gamma, rates, 1, 0, l)
        _rate(V, gamma, rates, 1, 1, l)
        _rate(V, gamma, rates, 1, 2, l)
        _rate(V, gamma, rates, 2, 0, l)
        _rate(V, gamma, rates, 2, 1, l)
        _rate(V, gamma, rates, 2, 2, l)
        _rate(V, gamma, rates, 3, 0, l)
        _rate(V, gamma, rates, 3, 1, l)
        _rate(V, gamma, rates, 3, 2, l)


@njit(cache=True, inline="always")
def _gains(blk, dt, kind, coefficient, gain):
    """The hourglass form's gain in every lane: the viscous k rho c V^(2/3) / 4, or the
    stiffness form's dt k rho c^2 (sum_I |b_I|^2) / (3 V)."""
    B = blk.b
    for l in range(LANES):
        rho, c = blk.rho[l], blk.c[l]
        if kind == STIFFNESS:
            bb = 0.0
            for k in range(8):
                b0 = B[(3 * k) * LANES + l]
                b1 = B[(3 * k + 1) * LANES + l]
                b2 = B[(3 * k + 2) * LANES + l]
                bb += b0 * b0 + b1 * b1 + b2 * b2
            gain[l] = dt * coefficient * rho * c * c * bb * blk.inv_volume[l] / 3.0
        else:
            gain[l] = 0.25 * coefficient * rho * c * blk.root2[l]


@njit(cache=True, inline="always")
def _generalized(rates, gain, resist, work, stiffness, dt):
    """Q_a of every lane into ``resist`` (the stiffness form adds to the stored Q_a) and
    the energy of the step into ``work``, term by term in the scalar path's order."""
    for l in range(LANES):
        w = 0.0
        for j in range(12):
            r = rates[j * LANES + l]
            if stiffness:
                old = resist[j * LANES + l]
                new = old + gain[l] * r
                resist[j * LANES + l] = new
                w += 0.5 * (old + new) * r
            else:
                new = gain[l] * r
                resist[j * LANES + l] = new
                w += new * r
        work[l] = dt * w


@njit(cache=True, inline="always")
def _subtract_mode(resist, gamma, fe, a, l):
    """f_I -= Q_a gamma_aI in lane l."""
    g0 = resist[(3 * a) * LANES + l]
    g1 = resist[(3 * a + 1) * LANES + l]
    g2 = resist[(3 * a + 2) * LANES + l]
    for k in range(8):
        h = gamma[(8 * a + k) * LANES + l]
        fe[(3 * k) * LANES + l] -= g0 * h
        fe[(3 * k + 1) * LANES + l] -= g1 * h
        fe[(3 * k + 2) * LANES + l] -= g2 * h


@njit(cache=True, inline="always")
def _subtract_forces(resist, gamma, fe):
    """f_I -= sum_a Q_a gamma_aI in every lane, mode by mode."""
    for l in range(LANES):
        _subtract_mode(resist, gamma, fe, 0, l)
        _subtract_mode(resist, gamma, fe, 1, l)
        _subtract_mode(resist, gamma, fe, 2, l)
        _subtract_mode(resist, gamma, fe, 3, l)


@njit(cache=True, inline="always")
def hourglass_forces(blk, dt, kind, coefficient):
    """pmpm.fem.elements.hourglass_forces in every lane, in stages that vectorise (the
    rates, the gains, the generalized forces with the work, the nodal forces); the
    generalized forces Q_a end in ``blk.resist`` (for the viscous form too, where they
    are not kept), the energy of the step in ``blk.work``."""
    _rates(blk.v, blk.gamma, blk.hg_rate)
    _gains(blk, dt, kind, coefficient, blk.gain)
    _generalized(blk.hg_rate, blk.gain, blk.resist, blk.work, kind == STIFFNESS, dt)
    _subtract_forces(blk.resist, blk.gamma, blk.fe)
