"""The particle and node loops of one explicit step (seed 000 Eqs. 12-16, seed 001 Eqs.
27-34), for the update-stress-first order (USF: stress update and force scatter in one
pass) and the modified update-stress-last order (MUSL: the same pass split in two).

Nodal arrays of a local block (flat, see ``pmpm.grid.LocalBlock``):
``nodal`` (n_nodes, 8): mass, momentum (3), rigid mass, rigid momentum (3);
``gvel`` (n_nodes, 3): velocity at the start of the step after boundary conditions;
``force`` (n_nodes, 3); ``gnew`` (n_nodes, 6): velocity at the end of the step and
acceleration.

Arguments come as records (``pmpm.kernels.records``): ``pts`` a PointState, ``mat`` a
MaterialState, ``bodies`` a BodyMaterials, ``loads`` an ExternalLoads, ``geo`` a
GridGeometry, ``block`` a NodeBlock, and ``contact`` a ContactView or None (then every
node carries the one shared field, and the contact code is compiled away). The particle
loops handle only the points with ``pts.level[p] == want`` (one grid of the hierarchy).

Speed: every kernel unpacks its records into local arrays before its loop. A record's
field read inside the loop, or a record passed to an inlined helper, costs a reference
count per particle (measured: the fused stress-and-force pass ran at 40 % of its speed).
"""
import numpy as np
from numba import njit

from ..materials.kernels import update_stress_columns
from .affine import affine_velocity_matrix, node_offsets
from .boundary import constrain_acceleration, constrain_velocity
from .layered import NO_LAYER, layer_plane, leave_layer, point_at, unpack
from .shape import LINEAR, MAX_NODES, point_axes, point_weights, stencil, weights

NODAL_COMPONENTS = 8


@njit(cache=True)
def particles_to_grid(pts, rigid, geo, nodal, want, affine=None, layers=None):
    """Scatter mass and momentum (Eqs. 12-13); rigid bodies also into the rigid slots.
    With ``affine`` (the particles' A_p, (n, 9), see ``pmpm.kernels.affine``; 27-node
    shapes only) a deformable particle's momentum at node i is m_p w_ip (v_p +
    B_p D_p^{-1} (x_i - x_p)) (APIC). With ``layers`` (a LayerSums, see
    ``pmpm.kernels.layered``) the sums are layer-ordered, the same on any rank count."""
    x, v, mass, body, level = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)            # a compile-time constant: see pmpm.kernels.shape
    nodes, axes, w = np.empty(MAX_NODES, np.int64), np.empty((9, 3)), np.empty(MAX_NODES)
    e, M = np.zeros((MAX_NODES, 3)), np.zeros((3, 3))
    order, count, axis, starts, halo, scratch, kept = unpack(layers, x.shape[0])
    acc, current, shift = nodal, NO_LAYER, 0
    if layers is not None:
        acc = scratch
    for i in range(count):
        p = point_at(layers, order, i)
        if level[p] != want:
            continue
        if layers is not None:
            layer = layer_plane(x, p, origin, inv_h, lo, axis)
            if layer != current:
                leave_layer(layer, current, nodal, acc, starts, halo, kept)
                current, shift = layer, starts[layer - halo]
        m = mass[p]
        slot = 4 if rigid[body[p]] else 0
        if shape != LINEAR and affine is None:      # the tensor product, row by row
            base, _ = point_weights(x, p, origin, inv_h, lo, strides, shape,
                                    half_width[body[p]], axes)
            v0, v1, v2 = v[p, 0], v[p, 1], v[p, 2]
            for a in range(3):
                for j in range(3):
                    mab = m * (axes[0, a] * axes[3, j])
                    row = base + a * strides[0] + j * strides[1]
                    for t in range(3):
                        n, mw = row + t * strides[2] - shift, mab * axes[6, t]
                        acc[n, slot] += mw
                        acc[n, slot + 1] += mw * v0
                        acc[n, slot + 2] += mw * v1
                        acc[n, slot + 3] += mw * v2
            continue
        reach = weights(x, p, origin, inv_h, lo, strides, shape, half_width[body[p]], axes,
                        nodes, w)
        if affine is not None and slot == 0:
            node_offsets(axes, e)
            affine_velocity_matrix(affine, p, axes, 1.0 / inv_h, M)
            _scatter_affine(acc, nodes, shift, w, e, reach, m, v[p, 0], v[p, 1], v[p, 2], M)
            continue
        v0, v1, v2 = v[p, 0], v[p, 1], v[p, 2]     # read once: ``acc`` might alias ``v``
        for k in range(reach):
            n, mw = nodes[k] - shift, m * w[k]
            acc[n, slot] += mw
            acc[n, slot + 1] += mw * v0
            acc[n, slot + 2] += mw * v1
            acc[n, slot + 3] += mw * v2
    if layers is not None:
        leave_layer(NO_LAYER, current, nodal, acc, starts, halo, kept)


@njit(cache=True, inline="always")
def _scatter_affine(nodal, nodes, shift, w, e, reach, m, v0, v1, v2, M):
    """Mass and the momentum m w_k (v + M e_k) of one particle onto its nodes (row
    ``nodes[k] - shift`` of ``nodal``)."""
    m00, m01, m02, m10, m11, m12 = M[0, 0], M[0, 1], M[0, 2], M[1, 0], M[1, 1], M[1, 2]
    m20, m21, m22 = M[2, 0], M[2, 1], M[2, 2]
    for k in range(reach):
        n, mw = nodes[k] - shift, m * w[k]
        e0, e1, e2 = e[k, 0], e[k, 1], e[k, 2]
        nodal[n, 0] += mw
        nodal[n, 1] += mw * (v0 + m00 * e0 + m01 * e1 + m02 * e2)
        nodal[n, 2] += mw * (v1 + m10 * e0 + m11 * e1 + m12 * e2)
        nodal[n, 3] += mw * (v2 + m20 * e0 + m21 * e1 + m22 * e2)


@njit(cache=True)
def nodal_velocities(nodal, block, m_tiny, gvel):
    """Velocity at the start of the step: momentum / mass, rigid bodies imposing theirs,
    then fixed and slip faces (``block.faces``; walls only against motion into them)."""
    faces, friction = block.faces, block.friction
    vec = np.empty(3)
    for n in range(gvel.shape[0]):
        vec[:] = 0.0
        if nodal[n, 4] > 0.0:
            for d in range(3):
                vec[d] = nodal[n, 5 + d] / nodal[n, 4]
        elif nodal[n, 0] > m_tiny:
            for d in range(3):
                vec[d] = nodal[n, 1 + d] / nodal[n, 0]
        if faces[n]:
            constrain_velocity(vec, faces[n], friction)
        gvel[n, 0], gvel[n, 1], gvel[n, 2] = vec[0], vec[1], vec[2]


@njit(cache=True)
def integrate_nodes(nodal, force, gvel, dt, block, m_tiny, gnew):
    """Leap-frog on the nodes (Eq. 14): a = f/m, v_new = v + a dt; rigid nodes keep the
    rigid velocity; fixed and slip faces constrain the acceleration, walls (slip faces
    with friction) with Coulomb's law."""
    faces, friction = block.faces, block.friction
    acc, vel = np.zeros(3), np.empty(3)
    for n in range(gnew.shape[0]):
        if nodal[n, 4] <= 0.0 and nodal[n, 0] > m_tiny:
            for d in range(3):
                acc[d] = force[n, d] / nodal[n, 0]
            if faces[n]:
                vel[0], vel[1], vel[2] = gvel[n, 0], gvel[n, 1], gvel[n, 2]
                constrain_acceleration(acc, vel, faces[n], friction, dt)
        else:
            acc[0] = acc[1] = acc[2] = 0.0
        for d in range(3):
            gnew[n, d] = gvel[n, d] + acc[d] * dt
            gnew[n, 3 + d] = acc[d]


@njit(cache=True)
def grid_to_particles(pts, rigid, dt, geo, gnew, contact, want, pic, affine=None):
    """Positions from the new nodal velocities (Eq. 15), velocities from the nodal
    accelerations (Eq. 16, FLIP); rigid particles move with their own velocity. At contact
    nodes a particle reads its own body's field ``cnew`` (seed 001 Eqs. 33-34). With
    ``pic`` > 0 the new velocity is ``(1 - pic)`` times the FLIP one plus ``pic`` times
    the new nodal velocity at the particle (PIC), which damps. With ``affine`` (APIC, see
    ``pmpm.kernels.affine``; 27-node shapes) the new velocity is the PIC one and the
    particle's A_p = sum_i w_ip v_i (x_i - x_p)^T / h^2 is gathered from the new nodal
    velocities at the start-of-step position (``pic`` is then not used; rigid particles
    keep A_p = 0). Returns the index of the first particle whose new position is not
    finite, else -1.

    The choice between a contact node's body field and the shared one is written out in
    both loops, the same ten lines twice on purpose: every helper tried made this pass
    ten times as slow or worse with contact (the steel ball, method 2: 33 ms a step
    against 3.3). A harness of the loop alone, 175,000 particles x 8 nodes: written out
    3.0 ms; a helper returning six values from either branch, inlined or not, 33.8; one
    adding into a 6-array, 41.9; one returning a single component, 164."""
    x, v, _, body, level = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)            # a compile-time constant: see pmpm.kernels.shape
    if contact is not None:
        slot_of, cnew = contact.slot_of, contact.cnew
    else:                       # no contact node: every node reads the shared field
        cnew = np.empty((0, 1, 6))
    nodes, axes, w = np.empty(MAX_NODES, np.int64), np.empty((9, 3)), np.empty(MAX_NODES)
    e = np.zeros((MAX_NODES, 3))
    bad = -1
    for p in range(x.shape[0]):
        if level[p] != want:
            continue
        if rigid[body[p]]:
            for d in range(3):
                x[p, d] += dt * v[p, d]
            continue
        b = body[p]
        dx0 = dx1 = dx2 = dv0 = dv1 = dv2 = 0.0
        if shape != LINEAR and affine is None:      # the tensor product, row by row
            base, _ = point_weights(x, p, origin, inv_h, lo, strides, shape, half_width[b],
                                    axes)
            for a in range(3):
                for j in range(3):
                    wab = axes[0, a] * axes[3, j]
                    row = base + a * strides[0] + j * strides[1]
                    for t in range(3):
                        n, wk = row + t * strides[2], wab * axes[6, t]
                        s = slot_of[n] if contact is not None else -1
                        if s < 0:       # written out: see the docstring
                            dx0, dx1, dx2 = (dx0 + wk * gnew[n, 0], dx1 + wk * gnew[n, 1],
                                             dx2 + wk * gnew[n, 2])
                            dv0, dv1, dv2 = (dv0 + wk * gnew[n, 3], dv1 + wk * gnew[n, 4],
                                             dv2 + wk * gnew[n, 5])
                        else:
                            dx0, dx1, dx2 = (dx0 + wk * cnew[s, b, 0], dx1 + wk * cnew[s, b, 1],
                                             dx2 + wk * cnew[s, b, 2])
                            dv0, dv1, dv2 = (dv0 + wk * cnew[s, b, 3], dv1 + wk * cnew[s, b, 4],
                                             dv2 + wk * cnew[s, b, 5])
        else:
            reach = weights(x, p, origin, inv_h, lo, strides, shape, half_width[b], axes,
                            nodes, w)
            for k in range(reach):
                n, wk = nodes[k], w[k]
                s = slot_of[n] if contact is not None else -1
                if s < 0:
                    dx0, dx1, dx2 = (dx0 + wk * gnew[n, 0], dx1 + wk * gnew[n, 1],
                                     dx2 + wk * gnew[n, 2])
                    dv0, dv1, dv2 = (dv0 + wk * gnew[n, 3], dv1 + wk * gnew[n, 4],
                                     dv2 + wk * gnew[n, 5])
                else:
                    dx0, dx1, dx2 = (dx0 + wk * cnew[s, b, 0], dx1 + wk * cnew[s, b, 1],
                                     dx2 + wk * cnew[s, b, 2])
                    dv0, dv1, dv2 = (dv0 + wk * cnew[s, b, 3], dv1 + wk * cnew[s, b, 4],
                                     dv2 + wk * cnew[s, b, 5])
        if affine is not None:
            _gather_affine(affine, p, b, nodes, w, axes, reach, inv_h, gnew, contact, e)
        x[p, 0] += dt * dx0
        x[p, 1] += dt * dx1
        x[p, 2] += dt * dx2
        v[p, 0] += dt * dv0
        v[p, 1] += dt * dv1
        v[p, 2] += dt * dv2
        if affine is not None:
            v[p, 0], v[p, 1], v[p, 2] = dx0, dx1, dx2
        elif pic > 0.0:
            v[p, 0] = (1.0 - pic) * v[p, 0] + pic * dx0
            v[p, 1] = (1.0 - pic) * v[p, 1] + pic * dx1
            v[p, 2] = (1.0 - pic) * v[p, 2] + pic * dx2
        if bad < 0 and not (np.isfinite(x[p, 0]) and np.isfinite(x[p, 1]) and np.isfinite(x[p, 2])):
            bad = p
    return bad


@njit(cache=True, inline="always")
def _gather_affine(affine, p, b, nodes, w, axes, reach, inv_h, gnew, contact, e):
    """affine[p] = sum_i w_ip v_i (x_i - x_p)^T / h^2 from the new nodal velocities (at
    contact nodes the particle's own body's, ``contact.cnew``); ``e`` is scratch."""
    node_offsets(axes, e)
    a00 = a01 = a02 = a10 = a11 = a12 = a20 = a21 = a22 = 0.0
    for k in range(reach):
        n = nodes[k]
        u0, u1, u2 = gnew[n, 0], gnew[n, 1], gnew[n, 2]
        if contact is not None:
            s = contact.slot_of[n]
            if s >= 0:
                u0, u1, u2 = contact.cnew[s, b, 0], contact.cnew[s, b, 1], contact.cnew[s, b, 2]
        we0, we1, we2 = w[k] * e[k, 0], w[k] * e[k, 1], w[k] * e[k, 2]
        a00 += u0 * we0
        a01 += u0 * we1
        a02 += u0 * we2
        a10 += u1 * we0
        a11 += u1 * we1
        a12 += u1 * we2
        a20 += u2 * we0
        a21 += u2 * we1
        a22 += u2 * we2
    affine[p, 0], affine[p, 1], affine[p, 2] = a00 * inv_h, a01 * inv_h, a02 * inv_h
    affine[p, 3], affine[p, 4], affine[p, 5] = a10 * inv_h, a11 * inv_h, a12 * inv_h
    affine[p, 6], affine[p, 7], affine[p, 8] = a20 * inv_h, a21 * inv_h, a22 * inv_h


@njit(cache=True)
def stress_and_forces(pts, mat, bodies, loads, dt, h, geo, gvel, force, contact, want,
                      stresses, forces, layers=None, clayers=None):
    """The particle pass of the step: with ``stresses``, update every particle's stress
    from the nodal velocities ``gvel`` (Eq. 29 and the material kernel); with ``forces``,
    scatter its internal and external force (Eqs. 31-32) to ``force``. USF does both in
    one pass; MUSL scatters the forces of the start of the step (``stresses`` False), and
    after the particles move updates the stresses from the velocities mapped back to the
    grid (``forces`` False). At contact nodes a particle sees its own body's velocity
    ``cvel`` and its force also goes to its body's ``cforce``. ``h`` is the level's cell
    size. With ``layers`` (a LayerSums for ``force``, see ``pmpm.kernels.layered``) the
    force sums are layer-ordered, the same on any rank count; ``clayers`` (one over the
    contact slots, rows (n_slots, n_bodies * 3)) does the same for ``cforce``.

    Returns
    -------
    (speed, bad): the largest wave speed plus particle speed (for the CFL step; 0 without
    ``stresses``), and the index of the first particle whose constitutive update failed
    (-1 if none).
    """
    x, v, mass, body, level = pts
    stress, F, rho, eps_p, e_int, temp, q, damage, w_p = mat
    codes, params, rigid = bodies
    gravity, load_vec, load, load_scale = loads
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)            # a compile-time constant: see pmpm.kernels.shape
    if contact is not None:
        slot_of, cvel, cforce = contact.slot_of, contact.cvel, contact.cforce
        cacc, cflat, cshift = cforce, cforce.reshape((cforce.shape[0], cforce.shape[1] * 3)), 0
        cstarts, cscratch, ckept = np.empty(0, np.int64), np.empty((0, 0)), np.empty((0, 0, 0))
        if clayers is not None:
            cstarts, cscratch, ckept = clayers.starts, clayers.scratch, clayers.kept
            cacc = cscratch.reshape((cscratch.shape[0], cforce.shape[1], 3))
    nodes, axes = np.empty(MAX_NODES, np.int64), np.empty((9, 3))
    w, gx, gy, gz = (np.empty(MAX_NODES), np.empty(MAX_NODES), np.empty(MAX_NODES),
                     np.empty(MAX_NODES))
    slots = np.full(MAX_NODES, -1, np.int64)
    Lg = np.empty((3, 3))
    fastest, bad = 0.0, -1
    base, reach = 0, MAX_NODES
    order, count, axis, starts, halo, scratch, kept = unpack(layers, x.shape[0])
    acc, current, shift = force, NO_LAYER, 0
    if layers is not None:
        acc = scratch
    for i in range(count):
        p = point_at(layers, order, i)
        if level[p] != want:
            continue
        if layers is not None:
            layer = layer_plane(x, p, origin, inv_h, lo, axis)
            if layer != current:
                leave_layer(layer, current, force, acc, starts, halo, kept)
                if contact is not None and clayers is not None:
                    leave_layer(layer, current, cflat, cscratch, cstarts, halo, ckept)
                    cshift = cstarts[layer - halo]
                current, shift = layer, starts[layer - halo]
        b = body[p]
        if rigid[b]:               # moves with its own velocity, which limits the step too
            if stresses:
                fastest = max(fastest, np.sqrt(v[p, 0] ** 2 + v[p, 1] ** 2 + v[p, 2] ** 2))
            continue
        if shape == LINEAR:
            reach = stencil(x, p, origin, inv_h, lo, strides, shape, half_width[b], axes,
                            nodes, w, gx, gy, gz)
            if contact is not None:     # every use of ``contact`` sits under a test of
                for k in range(reach):  # None, so Numba compiles it away without contact
                    slots[k] = slot_of[nodes[k]]
        else:
            base, _ = point_axes(x, p, origin, inv_h, lo, strides, shape, half_width[b],
                                 axes)
            for d in range(3):
                for j in range(3):
                    axes[3 * d + 1, j] *= inv_h
        if stresses:
            # L_ij = sum_I v_Ii dN_I/dx_j, written out (as an inlined call it cost 7 % of
            # the step in reference counting), summed in locals: LLVM cannot keep an
            # array's entries in registers across the loads of gvel (the same sums in the
            # same order; summed in Lg itself, the hats' whole step took 7 % longer)
            l00 = l01 = l02 = l10 = l11 = l12 = l20 = l21 = l22 = 0.0
            if shape == LINEAR:
                for k in range(reach):
                    n, s = nodes[k], -1
                    if contact is not None:
                        s = slots[k]
                    if s < 0:
                        u0, u1, u2 = gvel[n, 0], gvel[n, 1], gvel[n, 2]
                    elif contact is not None:
                        u0, u1, u2 = cvel[s, b, 0], cvel[s, b, 1], cvel[s, b, 2]
                    else:
                        continue
                    gxk, gyk, gzk = gx[k], gy[k], gz[k]
                    l00, l01, l02 = l00 + u0 * gxk, l01 + u0 * gyk, l02 + u0 * gzk
                    l10, l11, l12 = l10 + u1 * gxk, l11 + u1 * gyk, l12 + u1 * gzk
                    l20, l21, l22 = l20 + u2 * gxk, l21 + u2 * gyk, l22 + u2 * gzk
            else:                   # the tensor product, a row of 3 nodes at a time:
                for a in range(3):  # sum_c v (w_c, w'_c), then times the row's factors
                    for j in range(3):
                        row = base + a * strides[0] + j * strides[1]
                        s0 = s1 = s2 = t0 = t1 = t2 = 0.0
                        for t in range(3):
                            n = row + t * strides[2]
                            u0, u1, u2 = gvel[n, 0], gvel[n, 1], gvel[n, 2]
                            if contact is not None:
                                s = slot_of[n]
                                if s >= 0:
                                    u0, u1, u2 = cvel[s, b, 0], cvel[s, b, 1], cvel[s, b, 2]
                            wc, dc = axes[6, t], axes[7, t]
                            s0 += u0 * wc
                            s1 += u1 * wc
                            s2 += u2 * wc
                            t0 += u0 * dc
                            t1 += u1 * dc
                            t2 += u2 * dc
                        gxab, gyab = axes[1, a] * axes[3, j], axes[0, a] * axes[4, j]
                        wab = axes[0, a] * axes[3, j]
                        l00, l01, l02 = l00 + s0 * gxab, l01 + s0 * gyab, l02 + t0 * wab
                        l10, l11, l12 = l10 + s1 * gxab, l11 + s1 * gyab, l12 + t1 * wab
                        l20, l21, l22 = l20 + s2 * gxab, l21 + s2 * gyab, l22 + t2 * wab
            Lg[0, 0], Lg[0, 1], Lg[0, 2] = l00, l01, l02
            Lg[1, 0], Lg[1, 1], Lg[1, 2] = l10, l11, l12
            Lg[2, 0], Lg[2, 1], Lg[2, 2] = l20, l21, l22
            c = update_stress_columns(p, codes[b], params[b], dt, h, Lg, stress, F, rho,
                                      eps_p, e_int, temp, q, damage, w_p)
            if c < 0.0 and bad < 0:
                bad = p
            fastest = max(fastest, c + np.sqrt(v[p, 0] ** 2 + v[p, 1] ** 2 + v[p, 2] ** 2))
        if not forces:
            continue
        vol = mass[p] / rho[p]
        sxx, syy, szz = stress[p, 0] - q[p], stress[p, 1] - q[p], stress[p, 2] - q[p]
        sxy, syz, szx = stress[p, 3], stress[p, 4], stress[p, 5]
        ex, ey, ez = mass[p] * gravity[0], mass[p] * gravity[1], mass[p] * gravity[2]
        li, ls = load[p], load_scale[p]
        if li >= 0:
            ex += ls * load_vec[li, 0]
            ey += ls * load_vec[li, 1]
            ez += ls * load_vec[li, 2]
        if shape == LINEAR:
            for k in range(reach):
                n = nodes[k]
                f0 = w[k] * ex - vol * (sxx * gx[k] + sxy * gy[k] + szx * gz[k])
                f1 = w[k] * ey - vol * (sxy * gx[k] + syy * gy[k] + syz * gz[k])
                f2 = w[k] * ez - vol * (szx * gx[k] + syz * gy[k] + szz * gz[k])
                acc[n - shift, 0] += f0
                acc[n - shift, 1] += f1
                acc[n - shift, 2] += f2
                if contact is not None:
                    if slots[k] >= 0:
                        cacc[slots[k] - cshift, b, 0] += f0
                        cacc[slots[k] - cshift, b, 1] += f1
                        cacc[slots[k] - cshift, b, 2] += f2
            continue
        for a in range(3):          # f = w_c P_ab + w'_c Q_ab along each row of 3 nodes
            for j in range(3):
                row = base + a * strides[0] + j * strides[1]
                gxab, gyab = axes[1, a] * axes[3, j], axes[0, a] * axes[4, j]
                wab = axes[0, a] * axes[3, j]
                p0 = wab * ex - vol * (sxx * gxab + sxy * gyab)
                p1 = wab * ey - vol * (sxy * gxab + syy * gyab)
                p2 = wab * ez - vol * (szx * gxab + syz * gyab)
                q0, q1, q2 = -vol * szx * wab, -vol * syz * wab, -vol * szz * wab
                for t in range(3):
                    n = row + t * strides[2]
                    wc, dc = axes[6, t], axes[7, t]
                    f0, f1, f2 = wc * p0 + dc * q0, wc * p1 + dc * q1, wc * p2 + dc * q2
                    acc[n - shift, 0] += f0
                    acc[n - shift, 1] += f1
                    acc[n - shift, 2] += f2
                    if contact is not None:
                        s = slot_of[n]
                        if s >= 0:
                            cacc[s - cshift, b, 0] += f0
                            cacc[s - cshift, b, 1] += f1
                            cacc[s - cshift, b, 2] += f2
    if layers is not None:
        leave_layer(NO_LAYER, current, force, acc, starts, halo, kept)
        if contact is not None and clayers is not None:
            leave_layer(NO_LAYER, current, cflat, cscratch, cstarts, halo, ckept)
    return fastest, bad


@njit(cache=True)
def cell_keys(x, origin, inv_h, n_cells):
    """Flat coarse cell index of each particle (for sorting particles by cell)."""
    keys = np.empty(x.shape[0], np.int64)
    for p in range(x.shape[0]):
        i = np.int64(np.floor((x[p, 0] - origin[0]) * inv_h))
        j = np.int64(np.floor((x[p, 1] - origin[1]) * inv_h))
        k = np.int64(np.floor((x[p, 2] - origin[2]) * inv_h))
        keys[p] = (i * n_cells[1] + j) * n_cells[2] + k
    return keys


@njit(cache=True)
def slab_cell_keys(x, origin, inv_h, n_cells, axis):
    """Flat coarse cell index of each particle with the slab ``axis`` slowest (the cell
    layer along it leads, so that sorting by it orders the particles layer by layer)."""
    keys = np.empty(x.shape[0], np.int64)
    _slab_cell_keys_into(x, origin, inv_h, n_cells, axis, keys)
    return keys


@njit(cache=True, inline="always")
def _slab_cell_keys_into(x, origin, inv_h, n_cells, axis, keys):
    """:func:`slab_cell_keys` into ``keys``."""
    a, b = (1, 2) if axis == 0 else ((0, 2) if axis == 1 else (0, 1))
    for p in range(x.shape[0]):
        i = np.int64(np.floor((x[p, axis] - origin[axis]) * inv_h))
        j = np.int64(np.floor((x[p, a] - origin[a]) * inv_h))
        k = np.int64(np.floor((x[p, b] - origin[b]) * inv_h))
        keys[p] = (i * n_cells[a] + j) * n_cells[b] + k


@njit(cache=True)
def canonical_keys(x, ids, origin, inv_h, n_cells, axis, keys):
    """keys[p] = (cell of p with the slab ``axis`` slowest) * (largest id + 1) + id: one
    int64 that orders the particles by cell, then id. Returns False (keys not written)
    when that would not fit in 62 bits."""
    span = 1
    for p in range(ids.shape[0]):
        span = max(span, ids[p] + 1)
    if float(n_cells[0]) * float(n_cells[1]) * float(n_cells[2]) * float(span) >= 2.0 ** 62:
        return False
    _slab_cell_keys_into(x, origin, inv_h, n_cells, axis, keys)   # no temporary: it
    for p in range(ids.shape[0]):               # was page-faulted in at every call
        keys[p] = keys[p] * span + ids[p]
    return True


@njit(cache=True)
def sort_nearly_sorted(keys, order, most_moves):
    """Reorder ``order`` (n,) int64, a permutation of the particles, by their ``keys``
    (n,) in place, by insertion: O(n + moves) when ``order`` is almost sorted already
    (the last step's order: few particles change cells in a step). Gives up after
    ``most_moves`` moves and returns False (``order`` is then still a permutation; sort
    it another way)."""
    moves = 0
    for i in range(1, order.shape[0]):
        index = order[i]
        key = keys[index]
        j = i - 1
        while j >= 0 and keys[order[j]] > key:
            order[j + 1] = order[j]
            j -= 1
            moves += 1
        order[j + 1] = index
        if moves > most_moves:
            return False
    return True


@njit(cache=True)
def classify_particles(x, origin, inv_h, n_cells, axis, bounds, rank, owner):
    """Owner rank of every particle (-1 when it left the grid box). Returns the number
    outside and the number inside that ``rank`` does not own (those that move).

    Notes
    -----
    :func:`owners_and_spans` repeats this loop's body: as a ``forceinline`` helper it ran
    at 21 ns a particle instead of 1.4."""
    outside = 0
    moving = 0
    n_ranks = bounds.shape[0] - 1
    for p in range(x.shape[0]):
        c0 = np.floor((x[p, 0] - origin[0]) * inv_h)
        c1 = np.floor((x[p, 1] - origin[1]) * inv_h)
        c2 = np.floor((x[p, 2] - origin[2]) * inv_h)
        if (c0 < 0 or c1 < 0 or c2 < 0 or c0 >= n_cells[0] or c1 >= n_cells[1]
                or c2 >= n_cells[2]):
            owner[p] = -1
            outside += 1
            continue
        c = (c0, c1, c2)[axis]
        r = 0
        while r < n_ranks - 1 and c >= bounds[r + 1]:
            r += 1
        owner[p] = r
        moving += r != rank
    return outside, moving


@njit(cache=True)
def level_spans(x, level, origin, inv_h, n_cells, ratios, inv_hs, span):
    """The range of cells the particles of each grid level occupy, in that level's cell
    indices (``inv_hs[l]``: 1 / its cell size, ``ratios[l]``: its ratio): span[6 l : 6 l + 3] = -lowest,
    span[6 l + 3 : 6 l + 6] = highest (so that one MAX reduction over ranks gives both;
    -2^62 where a level has no particle). Particles outside the grid box are left out.
    One pass per level, its six extremes in locals: kept in the array, each particle's
    waited on the last one's stores (4.4 ns a particle against 3.1)."""
    for lv in range(span.shape[0] // 6):
        ih, top = inv_hs[lv], n_cells * ratios[lv] - 1.0
        lo0 = lo1 = lo2 = hi0 = hi1 = hi2 = -(2.0 ** 62)
        for p in range(x.shape[0]):
            if level[p] != lv:
                continue
            outside = False
            for d in range(3):
                if np.floor((x[p, d] - origin[d]) * inv_h) < 0 or \
                        np.floor((x[p, d] - origin[d]) * inv_h) >= n_cells[d]:
                    outside = True
            if outside:
                continue
            c0 = min(np.floor((x[p, 0] - origin[0]) * ih), top[0])
            c1 = min(np.floor((x[p, 1] - origin[1]) * ih), top[1])
            c2 = min(np.floor((x[p, 2] - origin[2]) * ih), top[2])
            lo0, lo1, lo2 = max(lo0, -c0), max(lo1, -c1), max(lo2, -c2)
            hi0, hi1, hi2 = max(hi0, c0), max(hi1, c1), max(hi2, c2)
        span[6 * lv], span[6 * lv + 1], span[6 * lv + 2] = lo0, lo1, lo2
        span[6 * lv + 3], span[6 * lv + 4], span[6 * lv + 5] = hi0, hi1, hi2


@njit(cache=True)
def owners_and_spans(x, level, origin, inv_h, n_cells, axis, bounds, rank, ratios, inv_hs,
                     owner, span):
    """:func:`classify_particles` and :func:`level_spans` in one pass over ``x`` for the
    first level (so one pass in all on a grid without refined windows), and a pass for
    each other level that takes the outside test from ``owner``: the same owners, counts
    and spans. Returns (outside, moving).

    Notes
    -----
    The end of the step read x three times before (owners 4.9, spans 3.3 and the moving
    count, NumPy on ``owner``, 3.0 ns a particle-step on the bar). Level 0's cells are
    the owners' (ratio 1, the same 1 / h): its span takes them, not three more floors
    (3.3 -> 2.3 ns a particle on random points in the bar's box)."""
    outside = 0
    moving = 0
    n_ranks = bounds.shape[0] - 1
    same = ratios[0] == 1 and inv_hs[0] == inv_h    # level 0's cells are the owners'
    for lv in range(span.shape[0] // 6):
        ih, top = inv_hs[lv], n_cells * ratios[lv] - 1.0
        lo0 = lo1 = lo2 = hi0 = hi1 = hi2 = -(2.0 ** 62)
        for p in range(x.shape[0]):
            if lv == 0:             # classify_particles' loop body
                c0 = np.floor((x[p, 0] - origin[0]) * inv_h)
                c1 = np.floor((x[p, 1] - origin[1]) * inv_h)
                c2 = np.floor((x[p, 2] - origin[2]) * inv_h)
                if (c0 < 0 or c1 < 0 or c2 < 0 or c0 >= n_cells[0] or c1 >= n_cells[1]
                        or c2 >= n_cells[2]):
                    owner[p] = -1
                    outside += 1
                    continue
                c = (c0, c1, c2)[axis]
                r = 0
                while r < n_ranks - 1 and c >= bounds[r + 1]:
                    r += 1
                owner[p] = r
                moving += r != rank
                if same and level[p] == 0:   # inside, so below top: the same span
                    lo0, lo1, lo2 = max(lo0, -c0), max(lo1, -c1), max(lo2, -c2)
                    hi0, hi1, hi2 = max(hi0, c0), max(hi1, c1), max(hi2, c2)
                    continue
            if level[p] != lv or owner[p] < 0:
                continue
            c0 = min(np.floor((x[p, 0] - origin[0]) * ih), top[0])
            c1 = min(np.floor((x[p, 1] - origin[1]) * ih), top[1])
            c2 = min(np.floor((x[p, 2] - origin[2]) * ih), top[2])
            lo0, lo1, lo2 = max(lo0, -c0), max(lo1, -c1), max(lo2, -c2)
            hi0, hi1, hi2 = max(hi0, c0), max(hi1, c1), max(hi2, c2)
        span[6 * lv], span[6 * lv + 1], span[6 * lv + 2] = lo0, lo1, lo2
        span[6 * lv + 3], span[6 * lv + 4], span[6 * lv + 5] = hi0, hi1, hi2
    return outside, moving
