"""Explicit hexahedral elements (Numba): one-point integration with the Flanagan-Belytschko
mean gradient, the stress update of the particles' material kernel, hourglass control,
lumped masses and the central-difference update of the nodes (seed 004 Eqs. 16-21;
``shared/seeds/004_NOTES.md`` Sec. 1.1).

Per element and step, from the nodal positions ``x`` and the half-step velocities ``v``:

1. ``b_I = dV/dx_I`` and V (:mod:`pmpm.fem.hexahedron`); V <= 0 is a fault;
2. ``L = sum_I v_I (x) b_I / V`` and the material update
   ``update_stress_columns`` on the element's row of the material columns, with the
   characteristic length ``L_e = V / largest face area`` (bulk viscosity);
3. internal force ``f_I = -(sigma - q I) b_I`` (the element volume times the stress times
   the mean gradient);
4. hourglass force ``f_I -= sum_a Q_a gamma_aI`` with the hourglass rates
   ``q_a = sum_I v_I gamma_aI`` and, per body, either the viscous form
   ``Q_a = k rho c V^(2/3) / 4 q_a`` or the stiffness form
   ``Q_a += dt k rho c^2 (sum_I |b_I|^2) / (3 V) q_a`` (k the case's coefficient); the
   energy the hourglass forces take is added to the element's hourglass energy
   (viscous: dissipated; stiffness: stored, as a trapezoid; its Q_a turn with the
   element's spin, :func:`rotate_resistance`); or, for the ``assumed_strain`` element
   (kind ASSUMED_STRAIN), the physical hourglass stiffness of
   :mod:`pmpm.fem.assumed_strain` in the element's corotational frame. The element's
   stable step includes the hourglass stiffness, the viscous forces and the bulk viscosity
   (:mod:`pmpm.fem.stability`, issue 27: the step L_e / c of before was 36 % too long on
   a cube at Poisson's ratio 0.3, and an FEM plate at cfl 0.95 grew its energy 7,500
   times).

Nothing here reads configuration or calls MPI; the arrays come in whole records.
"""
from collections import namedtuple

import numpy as np
from numba import njit

from ..materials.kernels import update_stress_columns
from ..materials.tensors import fdiv
from ..materials.layout import G
from .assumed_strain import (assumed_strain_forces, elastic_fraction, element_frame,
                             plate_moduli)
from . import lanes
from .hexahedron import hourglass_shapes, largest_face_area, mean_gradient
from .stability import ASSUMED_STRAIN, STIFFNESS, VISCOUS, stable_rate

#: hourglass forms (``Hourglass.kind``) of the reduced element: VISCOUS, STIFFNESS (from
#: pmpm.fem.stability); the assumed_strain element is the kind ASSUMED_STRAIN
HOURGLASS_KINDS = {"viscous": VISCOUS, "stiffness": STIFFNESS}
#: fault codes returned with the element index
NO_FAULT, NON_POSITIVE_VOLUME, FAILED_UPDATE = 0, 1, 2

#: Nodes and elements: ``x``, ``v`` (n, 3) positions and half-step velocities, ``hexes``
#: (m, 8) int64 node indices (VTK order), ``body`` (m,) int32 body index of each element.
ElementMesh = namedtuple("ElementMesh", "x v hexes body")
#: Per body ``kind`` (nb,) int64 (VISCOUS or STIFFNESS) and ``coefficient`` (nb,); per
#: element the stiffness form's generalized forces ``resist`` (m, 12) and the hourglass
#: energy ``energy`` (m,).
Hourglass = namedtuple("Hourglass", "kind coefficient resist energy")


@njit(cache=True)
def element_forces(mesh, mat, bodies, hourglass, dt, force, rates=None, contributions=None,
                   contribution_row=None):
    """Stress update and internal plus hourglass forces of every element, added to
    ``force`` (n, 3); with ``rates`` (n_elements,) each element's own stable rate too
    (0 for a rigid body's or a failed update, inf for an inverted element:
    FemBodies.step_rates, which a transfer's rule may read); with ``contributions``
    (rows, 8, 3), zeros, and ``contribution_row`` (n_elements,) the row of each element
    (-1: none), the nodal forces of the elements that have a row too (for sums over the
    nodes ranks share in element order, pmpm.comm.shared_nodes: the elements on shared
    nodes only).

    The elements go in blocks of pmpm.fem.lanes.LANES: a block of reduced elements of
    one deformable body, none inverted, runs lane by lane (SIMD, :mod:`pmpm.fem.lanes`),
    any other block element by element; both do each element's arithmetic in the same
    order and add the element forces to ``force`` in element order, so the answers do
    not depend on the blocks.

    Parameters
    ----------
    mesh : ElementMesh
    mat : pmpm.materials.state.MaterialState   one row per element, updated in place
    bodies : pmpm.kernels.records.BodyMaterials
    hourglass : Hourglass   ``resist`` and ``energy`` updated in place
    dt : float
    force : float64 (n, 3)

    Returns
    -------
    (rate, bad, why): the largest stable rate over the elements (1 / their stable
    time step at cfl 1, hourglass stiffness and damping included:
    :func:`pmpm.fem.stability.stable_rate`), the first faulty element (-1: none) and why (NON_POSITIVE_VOLUME,
    FAILED_UPDATE).
    """
    x, v, hexes, body = mesh
    stress, F, rho, eps_p, e_int, temp, q, damage, w_p = mat
    codes, params, rigid = bodies
    hg_kind, hg_coefficient, resist, hg_energy = hourglass     # unpacked before the loop
    xe, ve, b = np.empty((8, 3)), np.empty((8, 3)), np.empty((8, 3))
    gamma, fe, Lg = np.empty((4, 8)), np.empty((8, 3)), np.empty((3, 3))
    frame, half, qd, dq = np.empty((3, 3)), np.ones(3), np.empty((4, 3)), np.empty((4, 3))
    blk = lanes.new_block()
    rate, bad, why = 0.0, -1, NO_FAULT
    m = hexes.shape[0]
    for e0 in range(0, m, lanes.LANES):
        bb0 = body[e0]
        if e0 + lanes.LANES <= m and _reduced_block(body, rigid, hg_kind, e0):
            done, rate, bad, why = _block_forces(e0, blk, x, v, hexes, mat, codes[bb0],
                                                 params[bb0], hg_kind[bb0],
                                                 hg_coefficient[bb0], resist, hg_energy, dt,
                                                 force, rates, contributions,
                                                 contribution_row, Lg, rate, bad, why)
            if done:
                continue
        for e in range(e0, min(e0 + lanes.LANES, m)):      # element by element
            bb = body[e]
            if rigid[bb]:          # moves with its prescribed velocity: no stress, no force
                continue
            for k in range(8):
                n = hexes[e, k]
                for i in range(3):
                    xe[k, i] = x[n, i]
                    ve[k, i] = v[n, i]
            volume = mean_gradient(xe, b)
            if not volume > 0.0:
                if bad < 0:
                    bad, why = e, NON_POSITIVE_VOLUME
                if rates is not None:
                    rates[e] = np.inf
                continue
            inv_volume = fdiv(1.0, volume)      # no division with a raise path in the loop
            length = volume * fdiv(1.0, largest_face_area(xe))
            for i in range(3):
                for j in range(3):
                    s = 0.0
                    for k in range(8):
                        s += ve[k, i] * b[k, j]
                    Lg[i, j] = s * inv_volume
            eps_old = eps_p[e]
            c = update_stress_columns(e, codes[bb], params[bb], dt, length, Lg, stress, F,
                                      rho, eps_p, e_int, temp, q, damage, w_p)
            if not c >= 0.0:
                if bad < 0:
                    bad, why = e, FAILED_UPDATE
                continue
            stress_forces(stress, e, q[e], b, fe)
            hourglass_shapes(xe, b, inv_volume, gamma)
            if hg_kind[bb] == ASSUMED_STRAIN:
                element_frame(xe, frame, half)
            own = stable_rate(b, gamma, volume, length, rho[e], c, params[bb], hg_kind[bb],
                              hg_coefficient[bb], Lg[0, 0] + Lg[1, 1] + Lg[2, 2], half)
            rate = max(rate, own)
            if rates is not None:
                rates[e] = own
            if hg_kind[bb] == ASSUMED_STRAIN:
                hg_energy[e] += assumed_strain_forces(
                    e, ve, gamma, volume,
                    plate_moduli(rho[e], c, params[bb][G],
                                 elastic_fraction(Lg, dt, eps_p[e] - eps_old)),
                    frame, half, dt, resist, qd, dq, fe)
            else:
                if hg_kind[bb] == STIFFNESS:
                    rotate_resistance(resist, e, Lg, dt)
                hg_energy[e] += hourglass_forces(e, ve, b, gamma, volume, inv_volume,
                                                 rho[e], c, dt, hg_kind[bb],
                                                 hg_coefficient[bb], resist, fe)
            for k in range(8):
                n = hexes[e, k]
                for i in range(3):
                    force[n, i] += fe[k, i]
            if contributions is not None:
                r = contribution_row[e]
                if r >= 0:
                    for k in range(8):
                        for i in range(3):
                            contributions[r, k, i] = fe[k, i]
    return rate, bad, why


@njit(cache=True, inline="always")
def _reduced_block(body, rigid, hg_kind, e0):
    """Whether the LANES elements from e0 on are reduced elements (viscous or stiffness
    hourglass form) of one deformable body."""
    bb = body[e0]
    same = not (rigid[bb] or hg_kind[bb] == ASSUMED_STRAIN)
    for e in range(e0 + 1, e0 + lanes.LANES):
        same &= body[e] == bb
    return same                 # one exit (see _block_forces)


@njit(cache=True, inline="always")
def _block_forces(e0, blk, x, v, hexes, mat, code, prm, kind, coefficient, resist,
                  energy, dt, force, rates, contributions, contribution_row, Lg, rate, bad,
                  why):
    """element_forces on the block of LANES reduced elements from e0 on, lane by lane;
    returns (done, rate, bad, why), done False (and nothing changed) where an element of
    the block is inverted: the block then goes element by element.

    One exit, here and in the helpers it inlines: Numba keeps the reference counting of
    the arrays an inlined function takes where it returns from inside a loop (the FE
    nodes' force log took 125 ns a node so, 16 with one exit)."""
    lanes.gather(x, v, hexes, e0, blk.x, blk.v)
    lanes.mean_gradients(blk.x, blk.b, blk.volume)
    done = True
    for l in range(lanes.LANES):
        done &= blk.volume[l] > 0.0
    if done:
        rate, bad, why = _block_update(e0, blk, hexes, mat, code, prm, kind, coefficient,
                                       resist, energy, dt, force, rates, contributions,
                                       contribution_row, Lg, rate, bad, why)
    return done, rate, bad, why


@njit(cache=True, inline="always")
def _block_update(e0, blk, hexes, mat, code, prm, kind, coefficient, resist, energy, dt,
                  force, rates, contributions, contribution_row, Lg, rate, bad, why):
    """:func:`_block_forces` once the block's mean gradients and volumes are in ``blk``
    and every volume is positive; returns (rate, bad, why)."""
    stress, F, rho, eps_p, e_int, temp, q, damage, w_p = mat
    lanes.lengths(blk.x, blk.volume, blk.inv_volume, blk.length)
    lanes.velocity_gradients(blk.v, blk.b, blk.inv_volume, blk.lg)
    for l in range(lanes.LANES):            # the material update, element by element
        e = e0 + l
        for k in range(9):
            Lg[k // 3, k % 3] = blk.lg[k * lanes.LANES + l]
        c = update_stress_columns(e, code, prm, dt, blk.length[l], Lg, stress,
                                  F, rho, eps_p, e_int, temp, q, damage, w_p)
        blk.c[l], blk.rho[l], blk.ok[l] = c, rho[e], c >= 0.0
        if not c >= 0.0 and bad < 0:
            bad, why = e, FAILED_UPDATE
        for i in range(6):
            blk.sigma[i * lanes.LANES + l] = stress[e, i] - q[e] if i < 3 else stress[e, i]
    lanes.stress_forces(blk.sigma, blk.b, blk.fe)
    lanes.hourglass_shapes(blk.x, blk.b, blk.inv_volume, blk.gamma)
    lanes.cube_roots(kind, blk.volume, blk.root, blk.root2)
    lanes.stable_rates(blk, prm, kind, coefficient)
    if kind == STIFFNESS:
        for l in range(lanes.LANES):
            for j in range(12):
                blk.resist[j * lanes.LANES + l] = resist[e0 + l, j]
        lanes.rotate_resistances(blk.resist, blk.lg, dt)
    lanes.hourglass_forces(blk, dt, kind, coefficient)
    for l in range(lanes.LANES):            # in element order, as element by element
        if blk.ok[l]:
            rate = _block_element_done(e0 + l, l, blk, kind == STIFFNESS, hexes, resist,
                                       energy, force, rates, contributions,
                                       contribution_row, rate)
    return rate, bad, why


@njit(cache=True, inline="always")
def _block_element_done(e, l, blk, stiffness, hexes, resist, energy, force, rates,
                        contributions, contribution_row, rate):
    """Lane l's element e of a block: its rate, stored hourglass forces and energy, and
    its forces added to the nodes; returns the largest rate so far."""
    own = blk.own[l]
    rate = max(rate, own)
    if rates is not None:
        rates[e] = own
    if stiffness:
        for j in range(12):
            resist[e, j] = blk.resist[j * lanes.LANES + l]
    energy[e] += blk.work[l]
    for k in range(8):
        n = hexes[e, k]
        for i in range(3):
            force[n, i] += blk.fe[(3 * k + i) * lanes.LANES + l]
    if contributions is not None:
        r = contribution_row[e]
        if r >= 0:
            for k in range(8):
                for i in range(3):
                    contributions[r, k, i] = blk.fe[(3 * k + i) * lanes.LANES + l]
    return rate


@njit(cache=True, inline="always")
def stress_forces(stress, e, q, b, fe):
    """fe[I] = -(sigma - q I) b_I, sigma the Voigt row e (xx yy zz xy yz zx)."""
    sxx, syy, szz = stress[e, 0] - q, stress[e, 1] - q, stress[e, 2] - q
    sxy, syz, szx = stress[e, 3], stress[e, 4], stress[e, 5]
    for k in range(8):
        bx, by, bz = b[k, 0], b[k, 1], b[k, 2]
        fe[k, 0] = -(sxx * bx + sxy * by + szx * bz)
        fe[k, 1] = -(sxy * bx + syy * by + syz * bz)
        fe[k, 2] = -(szx * bx + syz * by + szz * bz)


@njit(cache=True, inline="always")
def hourglass_forces(e, ve, b, gamma, volume, inv_volume, rho, c, dt, kind, coefficient,
                     resist, fe):
    """Subtract the hourglass forces of element ``e`` from ``fe``; returns the energy
    they take over the step: dt sum_a Q_a . q_a for the viscous form (dissipated), and
    for the stiffness form the trapezoid dt sum_a (Q_a_old + Q_a) / 2 . q_a, which is
    the change of the stored k u^2 / 2 (with Q_a alone, it overcounts k (q dt)^2 / 2 every
    step: a ringing block reported 14 times the hourglass energy it held)."""
    if kind == STIFFNESS:
        bb = 0.0
        for k in range(8):
            bb += b[k, 0] * b[k, 0] + b[k, 1] * b[k, 1] + b[k, 2] * b[k, 2]
        gain = dt * coefficient * rho * c * c * bb * inv_volume / 3.0
    else:
        gain = 0.25 * coefficient * rho * c * np.cbrt(volume * volume)
    work = 0.0
    for a in range(4):
        r0 = r1 = r2 = 0.0
        for k in range(8):
            r0 += ve[k, 0] * gamma[a, k]
        for k in range(8):
            r1 += ve[k, 1] * gamma[a, k]
        for k in range(8):
            r2 += ve[k, 2] * gamma[a, k]
        if kind == STIFFNESS:
            o0, o1, o2 = resist[e, 3 * a], resist[e, 3 * a + 1], resist[e, 3 * a + 2]
            g0, g1, g2 = o0 + gain * r0, o1 + gain * r1, o2 + gain * r2
            resist[e, 3 * a], resist[e, 3 * a + 1], resist[e, 3 * a + 2] = g0, g1, g2
            work += 0.5 * (o0 + g0) * r0
            work += 0.5 * (o1 + g1) * r1
            work += 0.5 * (o2 + g2) * r2
        else:
            g0, g1, g2 = gain * r0, gain * r1, gain * r2
            work += g0 * r0
            work += g1 * r1
            work += g2 * r2
        for k in range(8):
            fe[k, 0] -= g0 * gamma[a, k]
            fe[k, 1] -= g1 * gamma[a, k]
            fe[k, 2] -= g2 * gamma[a, k]
    return dt * work


@njit(cache=True, inline="always")
def rotate_resistance(resist, e, Lg, dt):
    """Turn the stiffness form's generalized forces Q_a (vectors in global axes) with the
    element's spin W = (L - L^T)/2 over the step, Q_a += dt W Q_a, so that a spinning
    element's stored hourglass forces turn with it (as the stress's Jaumann rate)."""
    w01 = 0.5 * (Lg[0, 1] - Lg[1, 0]) * dt
    w02 = 0.5 * (Lg[0, 2] - Lg[2, 0]) * dt
    w12 = 0.5 * (Lg[1, 2] - Lg[2, 1]) * dt
    for a in range(4):
        q0, q1, q2 = resist[e, 3 * a], resist[e, 3 * a + 1], resist[e, 3 * a + 2]
        resist[e, 3 * a] = q0 + w01 * q1 + w02 * q2
        resist[e, 3 * a + 1] = q1 - w01 * q0 + w12 * q2
        resist[e, 3 * a + 2] = q2 - w02 * q0 - w12 * q1


@njit(cache=True)
def lumped_masses(hexes, volumes, densities, mass):
    """mass[n] = sum over the elements at node n of rho0 V0 / 8 (``mass`` zeroed first)."""
    mass[:] = 0.0
    for e in range(hexes.shape[0]):
        share = densities[e] * volumes[e] / 8.0
        for k in range(8):
            mass[hexes[e, k]] += share


@njit(cache=True)
def external_forces(mass, gravity, load, load_scale, load_vectors, force):
    """Add gravity m g and each loaded node's share ``load_scale * load_vectors[load]``
    (``load`` -1: none) to ``force``."""
    for n in range(mass.shape[0]):
        for i in range(3):
            force[n, i] += mass[n] * gravity[i]
        if load[n] >= 0:
            for i in range(3):
                force[n, i] += load_scale[n] * load_vectors[load[n], i]


@njit(cache=True)
def advance_velocities(v, force, mass, fixed, dt):
    """Central difference v <- v + dt f / m at the nodes; then the constraints: ``fixed``
    (n, 3) bool, True where that velocity component is held at zero."""
    for n in range(v.shape[0]):
        inv = dt * fdiv(1.0, mass[n])
        for i in range(3):
            v[n, i] = 0.0 if fixed[n, i] else v[n, i] + force[n, i] * inv


@njit(cache=True)
def advance_positions(x, v, dt):
    """x <- x + dt v (v the new half-step velocity); returns the first node whose
    position is not finite (-1: none)."""
    bad = -1
    for n in range(x.shape[0]):
        for i in range(3):
            x[n, i] += dt * v[n, i]
        if bad < 0 and not (np.isfinite(x[n, 0]) and np.isfinite(x[n, 1])
                            and np.isfinite(x[n, 2])):
            bad = n
    return bad
