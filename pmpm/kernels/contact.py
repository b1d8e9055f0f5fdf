"""Multi-velocity grid contact (seed 001 Secs. 2-4): the node loops.

Every body keeps its own nodal field only at *contact nodes*, the nodes that particles
of two or more bodies reach; everywhere else the single shared field of ``mpm`` is the
field of the one body there. Contact nodes are numbered in increasing local node order
("slots"), so the slots of one slab plane are one contiguous range.

Per-slot arrays, shape (n_slots, n_bodies, c):
``cnodal`` c = 10: mass, momentum (3), mass gradient sum_p m_p G_ip (3) (Eq. 9: it
points from a body's particles out to the node), and the mass-weighted offset of the
particles from the node in cells, sum_p m_p N_ip (x_p - x_i)/h (3), for the
separation check;
``cvel`` c = 3: velocity at the start of the step (Eq. 6; Eq. 25 applied by method 2);
``cnorm`` c = 3: collinear unit outward normal (Sec. 2.3);
``cforce`` c = 3: internal + external force of the body alone (Eq. 31);
``cnew`` c = 6: velocity at the end of the step (Eq. 14) and acceleration (Eq. 34).

The per-slot arrays travel together as a ``ContactSlots`` record, the pair tables,
shape (n_bodies, n_bodies), as a ``PairRules`` record: ``friction`` (Coulomb mu),
``master`` (-1: average of the two normals, Eq. 10; else the body whose own normal both
use) and ``separation`` (cells; inf: no separation check); see ``pmpm.kernels.records``.
"""
import numpy as np
from numba import njit

from .affine import affine_velocity_matrix
from .layered import NO_LAYER, layer_plane, leave_layer, point_at, unpack
from .boundary import constrain_coded, mirrors
from .shape import point_axes

CNODAL, CVEL, CNEW = 10, 3, 6
#: which pairs :func:`contact_end` leaves uncorrected where they separated at the start
SKIP_NONE, SKIP_FRICTIONLESS, SKIP_ALL = 0, 1, 2


@njit(cache=True)
def body_masks(pts, geo, mask, want):
    """mask[n] |= 1 << body for every node the shape functions of a point of ``pts`` (a
    PointState) with ``level[p] == want`` reach; ``geo`` a GridGeometry."""
    x, _, _, body, level = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)            # a compile-time constant: see pmpm.kernels.shape
    axes = np.empty((9, 3))
    for p in range(x.shape[0]):
        if level[p] != want:
            continue
        base, reach = point_axes(x, p, origin, inv_h, lo, strides, shape,
                                 half_width[body[p]], axes)
        bit = np.int64(1) << np.int64(body[p])
        for a in range(reach):
            for b in range(reach):
                for c in range(reach):
                    mask[base + a * strides[0] + b * strides[1] + c * strides[2]] |= bit


@njit(cache=True)
def number_contact_nodes(mask, slot_of):
    """slot_of[n] = slot of node n if two or more bodies reach it, else -1; returns the
    nodes of the slots in order."""
    count = 0
    for n in range(mask.shape[0]):
        m = mask[n]
        if m & (m - 1):
            slot_of[n] = count
            count += 1
        else:
            slot_of[n] = -1
    nodes = np.empty(count, np.int64)
    for n in range(mask.shape[0]):
        if slot_of[n] >= 0:
            nodes[slot_of[n]] = n
    return nodes


@njit(cache=True)
def contact_particles_to_grid(pts, geo, slot_of, cnodal, want, affine=None, layers=None):
    """Each body's mass, momentum, mass gradient (Eqs. 27-28, 9) and mass-weighted
    offset from the node (in cells) at the contact nodes, from the points with
    ``level[p] == want``. With ``affine`` (APIC, ``pmpm.kernels.affine``) the momentum
    carries the particle's affine velocity as in ``pmpm.kernels.mpm.particles_to_grid``,
    so that each body's momentum sums to the shared field's. With ``layers`` (a
    LayerSums over the slots, rows (n_slots, n_bodies * CNODAL)) the sums are
    layer-ordered (``pmpm.kernels.layered``), the same on any rank count."""
    x, v, mass, body, level = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)            # a compile-time constant: see pmpm.kernels.shape
    axes = np.empty((9, 3))
    M = np.zeros((3, 3))
    nb = cnodal.shape[1]
    flat = cnodal.reshape((cnodal.shape[0], nb * CNODAL))
    order, count, axis, starts, halo, scratch, kept = unpack(layers, x.shape[0])
    acc, current, shift = cnodal, NO_LAYER, 0
    if layers is not None:
        acc = scratch.reshape((scratch.shape[0], nb, CNODAL))
    for i in range(count):
        p = point_at(layers, order, i)
        if level[p] != want:
            continue
        if layers is not None:
            layer = layer_plane(x, p, origin, inv_h, lo, axis)
            if layer != current:
                leave_layer(layer, current, flat, scratch, starts, halo, kept)
                current, shift = layer, starts[layer - halo]
        b, m = body[p], mass[p]
        base, reach = point_axes(x, p, origin, inv_h, lo, strides, shape, half_width[b], axes)
        if affine is not None:
            affine_velocity_matrix(affine, p, axes, 1.0 / inv_h, M)
        for a in range(reach):
            for bb in range(reach):
                for cc in range(reach):
                    s = slot_of[base + a * strides[0] + bb * strides[1] + cc * strides[2]]
                    if s < 0:
                        continue
                    s -= shift
                    wx, wy, wz = axes[0, a], axes[3, bb], axes[6, cc]
                    mw = m * wx * wy * wz
                    acc[s, b, 0] += mw
                    if affine is not None:
                        e0, e1, e2 = -axes[2, a], -axes[5, bb], -axes[8, cc]
                        for d in range(3):
                            acc[s, b, 1 + d] += mw * (v[p, d] + M[d, 0] * e0
                                                      + M[d, 1] * e1 + M[d, 2] * e2)
                    else:
                        acc[s, b, 1] += mw * v[p, 0]
                        acc[s, b, 2] += mw * v[p, 1]
                        acc[s, b, 3] += mw * v[p, 2]
                    acc[s, b, 4] += m * (axes[1, a] * inv_h) * wy * wz
                    acc[s, b, 5] += m * wx * (axes[4, bb] * inv_h) * wz
                    acc[s, b, 6] += m * wx * wy * (axes[7, cc] * inv_h)
                    acc[s, b, 7] += mw * axes[2, a]
                    acc[s, b, 8] += mw * axes[5, bb]
                    acc[s, b, 9] += mw * axes[8, cc]
    if layers is not None:
        leave_layer(NO_LAYER, current, flat, scratch, starts, halo, kept)


@njit(cache=True, inline="always")
def _normalise(vec):
    size = np.sqrt(vec[0] ** 2 + vec[1] ** 2 + vec[2] ** 2)
    if size > 0.0:
        for d in range(3):
            vec[d] /= size
    return size


@njit(cache=True, inline="always")
def _heaviest_other(cnodal, s, b, m_tiny):
    other, heaviest = -1, m_tiny
    for c in range(cnodal.shape[1]):
        if c != b and cnodal[s, c, 0] > heaviest:
            other, heaviest = c, cnodal[s, c, 0]
    return other


@njit(cache=True)
def _collinear_normal(cnodal, s, b, other, master, code, rest, out, flat):
    """The outward normal of body b at slot s against the heaviest other body there:
    the master body's own normal (Sec. 2.3 choices 1-2), else Eq. 10 generalised to
    (n_b - n_rest)/|n_b - n_rest| with n_rest the normal of all other bodies together.
    The mass gradients first lose their components along the normals of the constrained
    faces the node lies on (:func:`pmpm.kernels.boundary.constrain_coded`, ``code``: the node's face codes): a slip
    or symmetry face is a mirror plane, the body's image beyond it has the opposite
    gradient along the face normal, so the surface normal there lies in the face (in a
    one-cell plane-strain slab every node is on such a face). ``rest`` is scratch space.

    With ``flat`` > 0 (the release rule: :data:`FLAT`), a body whose mass gradient per
    unit mass at the node is below ``flat`` times the other's has no surface there (the
    node lies inside it, under a surface that the other body's outermost particles
    reach): the other body's normal alone is taken. Normalised, that small gradient
    (round-off, or the body's slight non-uniformity) points anywhere, and the contact
    would push along it. ``flat`` = 0 keeps seed 001's normals."""
    k = master[b, other]
    if k >= 0:
        j = other if k == b else b
        if _spread(cnodal, s, k) < flat * _spread(cnodal, s, j):
            k = j                                  # the master has no surface here
        sign = 1.0 if k == b else -1.0
        for d in range(3):
            out[d] = sign * cnodal[s, k, 4 + d]
        constrain_coded(out, code)
        _normalise(out)
        return
    rest[0] = rest[1] = rest[2] = 0.0
    rest_mass = 0.0
    for c in range(cnodal.shape[1]):
        if c != b:
            rest_mass += cnodal[s, c, 0]
            for d in range(3):
                rest[d] += cnodal[s, c, 4 + d]
    rest_spread = np.sqrt(rest[0] ** 2 + rest[1] ** 2 + rest[2] ** 2) / rest_mass
    own_spread = _spread(cnodal, s, b)
    constrain_coded(rest, code)
    _normalise(rest)
    for d in range(3):
        out[d] = cnodal[s, b, 4 + d] if own_spread >= flat * rest_spread else 0.0
        rest[d] = rest[d] if rest_spread >= flat * own_spread else 0.0
    constrain_coded(out, code)
    _normalise(out)
    for d in range(3):
        out[d] -= rest[d]
    _normalise(out)


#: Under the release rule a body has no surface at a node where its mass gradient per
#: unit mass is below this fraction of the other body's there (a surface node's is of
#: order 1 / cell, a node inside a body's is round-off or its slight non-uniformity).
FLAT = 0.05


@njit(cache=True, inline="always")
def _spread(cnodal, s, c):
    """|grad m_c| / m_c of body c at slot s (1/length; 0 without mass)."""
    m = cnodal[s, c, 0]
    if m <= 0.0:
        return 0.0
    return np.sqrt(cnodal[s, c, 4] ** 2 + cnodal[s, c, 5] ** 2 + cnodal[s, c, 6] ** 2) / m


@njit(cache=True, inline="always")
def _separated(cnodal, s, b, other, normal, limit):
    """True when the mean positions of the particles of b and of ``other`` at slot s lie
    more than ``limit`` cells apart along b's outward normal: the surfaces still have a
    gap between them, whatever their velocities (the displacement check of Lemiale et
    al. 2010 and Nairn 2013, with positions). With linear shape functions touching flat
    surfaces are 2/3 to 3/4 of a cell apart where both bodies reach the node well, up to
    1 cell where one barely does; a gap adds to that."""
    gap = 0.0
    for d in range(3):
        gap += (cnodal[s, other, 7 + d] / cnodal[s, other, 0]
                - cnodal[s, b, 7 + d] / cnodal[s, b, 0]) * normal[d]
    return gap > limit


@njit(cache=True)
def contact_start(slots, gvel, rules, body_rigid, method, m_tiny, block, flat=0.0):
    """Per-body velocities (Eq. 6) and collinear normals at the contact nodes; method 2
    sets the normal velocity of each approaching body to the centre of mass's (Eqs. 23,
    25, slip form), within the node's boundary conditions, unless the two bodies are
    separated there (:func:`_separated`). ``gvel`` is the shared (centre-of-mass, Eq. 7)
    velocity; ``flat``: see :func:`_collinear_normal`. Writes ``slots.cvel`` and
    ``slots.cnorm``."""
    cnodal, slot_nodes, cvel, cnorm, _, _ = slots
    master, _, separation = rules
    faces = block.faces
    vec, rest = np.empty(3), np.empty(3)
    for s in range(slot_nodes.shape[0]):
        n = slot_nodes[s]
        for b in range(cnodal.shape[1]):
            m = cnodal[s, b, 0]
            cnorm[s, b, 0] = cnorm[s, b, 1] = cnorm[s, b, 2] = 0.0
            for d in range(3):
                vec[d] = cnodal[s, b, 1 + d] / m if m > m_tiny else gvel[n, d]
            constrain_coded(vec, faces[n])
            other = _heaviest_other(cnodal, s, b, m_tiny) if m > m_tiny else -1
            if other >= 0:
                _collinear_normal(cnodal, s, b, other, master, faces[n], rest,
                                  cnorm[s, b], flat)
                if method == 2 and not body_rigid[b] and not _separated(
                        cnodal, s, b, other, cnorm[s, b], separation[b, other]):
                    approach = 0.0
                    for d in range(3):
                        approach += (vec[d] - gvel[n, d]) * cnorm[s, b, d]
                    if approach > 0.0:
                        for d in range(3):
                            vec[d] -= approach * cnorm[s, b, d]
                        constrain_coded(vec, faces[n])
            for d in range(3):
                cvel[s, b, d] = vec[d]


@njit(cache=True)
def balance_start(slots, body_rigid, m_tiny, block):
    """Method 2's start corrections (:func:`contact_start`, each approaching body's
    normal velocity set to the centre of mass's; less those the release rule undid,
    :func:`release_open_gaps`), balanced as :func:`_balance_corrections` balances the
    end's: where three bodies or more meet at a slot, their net change of momentum, per
    unit of the node's mass, is taken off every body there (the same shift for all: their
    relative velocities, and so the removed approach, are kept). Two bodies' corrections
    cancel (and the release rule's gap is the same for both: the volume gap is symmetric
    in the pair, the extents' gap is taken along opposite normals), and a rigid body imposes
    its velocity: those slots are left as they are. Writes ``slots.cvel``."""
    cnodal, slot_nodes, cvel, _, _, _ = slots
    net, own = np.empty(3), np.empty(3)
    for s in range(slot_nodes.shape[0]):
        code = block.faces[slot_nodes[s]]
        total = _net_change(cnodal, cnodal, 1, cvel, 0, body_rigid, m_tiny, code, s, net,
                            own)
        if total > 0.0:
            for b in range(cnodal.shape[1]):
                if cnodal[s, b, 0] > m_tiny:
                    for d in range(3):
                        cvel[s, b, d] -= net[d] / total


@njit(cache=True)
def _net_change(cnodal, before, at, after, to, body_rigid, m_tiny, code, s, net, own):
    """``net`` = sum over the bodies b at slot ``s`` of m_b times the change of their
    velocity by the contact: ``after[s, b, to:to + 3]`` less ``before[s, b, at:at + 3]``
    / m_b within the node's faces. Returns the node's mass where three bodies or more
    meet, else 0 (no balance needed: two bodies' corrections cancel, and a rigid body
    imposes its velocity)."""
    present, total = 0, 0.0
    for d in range(3):
        net[d] = 0.0
    for b in range(cnodal.shape[1]):
        m = cnodal[s, b, 0]
        if m <= m_tiny:
            continue
        if body_rigid[b]:
            return 0.0
        present += 1
        total += m
        for d in range(3):
            own[d] = before[s, b, at + d] / m
        constrain_coded(own, code)
        for d in range(3):
            net[d] += m * (after[s, b, to + d] - own[d])
    return total if present >= 3 else 0.0


@njit(cache=True)
def contact_end(slots, gvel, gnew, rules, body_rigid, skip_separating, dt, m_tiny, block,
                start_share):
    """Trial velocities of each body alone (Eqs. 11, 26); where a body approaches the
    centre of mass (Eq. 12) and is not separated from the other body (:func:`_separated`)
    the contact force of Eq. 22 (normal part Eq. 17, no-slip tangential part Eq. 21
    limited by Coulomb friction) corrects it (Eq. 14).
    ``gnew[:, :3]`` is the shared trial velocity, i.e. the centre of mass's (Eq. 13),
    ``gvel`` the start-of-step one.

    ``skip_separating`` (method 2 only; SKIP_NONE, SKIP_FRICTIONLESS or SKIP_ALL): a
    body of such a pair that separated from the centre of mass at the start of the step
    (Eq. 23 false, before its start correction) is not corrected at the end: the
    particles' velocities still separate there, and the correction would do positive
    work on them (the elastic rings of seed 001 Sec. 5.1 gained 20-30 % of their energy
    so, an elastic sphere up to 36 %). With friction the skip also drops the friction,
    and a block at rest on a ringing slope slipped (keeping the friction alone broke
    Coulomb's ratio), so SKIP_FRICTIONLESS skips frictionless pairs only. SKIP_NONE:
    Eq. 12 alone decides, as in the paper.

    Friction is limited to mu times the normal part of this correction plus
    ``start_share[b]`` times method 2's start correction (Eq. 25, normal only): the
    share of it that reaches body b's velocities (APIC takes the new nodal velocity, so
    all of it; FLIP only the acceleration, so none; a FLIP/PIC blend its PIC fraction).
    Seed 001's contact passes zeros. So a body sliding through an impact takes mu times
    the normal impulse it receives (docs/validation/angular_momentum.md). Writes
    ``slots.cnew``."""
    acc, tangent = np.empty(3), np.empty(3)
    faces = block.faces
    cnodal, slot_nodes, cvel, cnorm, cforce, cnew = slots
    _, friction, separation = rules
    for s, n in enumerate(slot_nodes):
        for b in range(cnodal.shape[1]):
            m = cnodal[s, b, 0]
            if m <= m_tiny or body_rigid[b]:
                cnew[s, b, :] = gnew[n, :]
                continue
            for d in range(3):
                acc[d] = cforce[s, b, d] / m
            constrain_coded(acc, faces[n])
            other = _heaviest_other(cnodal, s, b, m_tiny)
            if other >= 0 and not _separated(cnodal, s, b, other, cnorm[s, b],
                                             separation[b, other]):
                approach = 0.0
                for d in range(3):
                    approach += (cvel[s, b, d] + acc[d] * dt - gnew[n, d]) * cnorm[s, b, d]
                before = 0.0               # the approach at the start of the step
                if skip_separating == SKIP_ALL or (skip_separating == SKIP_FRICTIONLESS
                                                   and friction[b, other] == 0.0):
                    for d in range(3):
                        before += (cnodal[s, b, 1 + d] / m - gvel[n, d]) * cnorm[s, b, d]
                if approach > 0.0 and before >= 0.0:
                    started = 0.0          # Eq. 25's normal change the body keeps
                    if start_share[b] > 0.0:
                        # against the body's own velocity within the node's faces, so
                        # a fixed or slip face's share is not counted as contact
                        for d in range(3):
                            tangent[d] = cnodal[s, b, 1 + d] / m
                        constrain_coded(tangent, faces[n])
                        for d in range(3):
                            started += (cvel[s, b, d] - tangent[d]) * cnorm[s, b, d]
                        started *= start_share[b]
                    _add_contact_acceleration(cvel[s, b], acc, cnorm[s, b], gnew[n],
                                              friction[b, other], dt, tangent, started / dt)
                    constrain_coded(acc, faces[n])
            for d in range(3):
                cnew[s, b, d] = cvel[s, b, d] + acc[d] * dt
                cnew[s, b, 3 + d] = acc[d]
        _balance_corrections(cnodal, cforce, cnew, body_rigid, m_tiny, faces[n], s, dt,
                             acc, tangent)


@njit(cache=True)
def _balance_corrections(cnodal, cforce, cnew, body_rigid, m_tiny, code, s, dt, net, own):
    """Where three bodies or more meet at slot ``s``, each is corrected against the
    centre of mass along its own normal, and their corrections need not sum to zero
    (two bodies have opposite normals and approach it together: theirs do). Their net,
    per unit of the node's mass, is taken off every body there, so that the contact
    keeps momentum (an ogive rod's FE nodes, its plate's and the plate's converted
    particles at one node: 0.2 % of the momentum a step). Nodes of two bodies, and
    nodes with a rigid body (which imposes its velocity), are left as they are.
    ``net``, ``own``: scratch 3-vectors."""
    total = _net_change(cnodal, cforce, 0, cnew, 3, body_rigid, m_tiny, code, s, net, own)
    if total == 0.0:
        return
    for b in range(cnodal.shape[1]):
        if cnodal[s, b, 0] <= m_tiny:
            continue
        for d in range(3):
            cnew[s, b, 3 + d] -= net[d] / total
            cnew[s, b, d] -= net[d] / total * dt


@njit(cache=True, inline="always")
def _add_contact_acceleration(v0, acc, normal, cm_new, mu, dt, tangent, started):
    """acc += f_ct / m (Eq. 22), all per unit mass: the stick correction
    (v_cm - v_trial)/dt split into its normal part and the tangential rest, the latter
    limited to mu times the normal part plus ``started`` (the normal change already
    made this step, per unit time; both point the same way)."""
    normal_part = 0.0
    for d in range(3):
        tangent[d] = (cm_new[d] - v0[d] - acc[d] * dt) / dt
        normal_part += tangent[d] * normal[d]
    for d in range(3):
        tangent[d] -= normal_part * normal[d]
    stick = _normalise(tangent)
    slide = min(mu * abs(normal_part + started), stick)
    for d in range(3):
        acc[d] += normal_part * normal[d] + slide * tangent[d]


CEXT = 6


@njit(cache=True)
def contact_extents(pts, geo, slot_of, cext, want):
    """The farthest reach of each body's particles at the contact nodes, for the release
    rule (:func:`release_open_gaps`): ``cext[s, b, d]`` (d < 3) is the largest offset
    (x_p - x_i)/h along +axis d of a particle of body b that the shape functions of node
    s weigh, ``cext[s, b, 3 + d]`` the largest along -d; in cells, -inf where b has no
    particle. Start from -inf; combine ranks with a maximum."""
    x, v, mass, body, level = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)            # a compile-time constant: see pmpm.kernels.shape
    axes = np.empty((9, 3))
    for p in range(x.shape[0]):
        if level[p] != want:
            continue
        b = body[p]
        base, reach = point_axes(x, p, origin, inv_h, lo, strides, shape, half_width[b], axes)
        for a in range(reach):
            for bb in range(reach):
                for cc in range(reach):
                    if axes[0, a] * axes[3, bb] * axes[6, cc] <= 0.0:
                        continue
                    s = slot_of[base + a * strides[0] + bb * strides[1] + cc * strides[2]]
                    if s < 0:
                        continue
                    off0, off1, off2 = axes[2, a], axes[5, bb], axes[8, cc]
                    cext[s, b, 0] = max(cext[s, b, 0], off0)
                    cext[s, b, 1] = max(cext[s, b, 1], off1)
                    cext[s, b, 2] = max(cext[s, b, 2], off2)
                    cext[s, b, 3] = max(cext[s, b, 3], -off0)
                    cext[s, b, 4] = max(cext[s, b, 4], -off1)
                    cext[s, b, 5] = max(cext[s, b, 5], -off2)


@njit(cache=True, inline="always")
def surface_gap(cext, s, b, other, normal, half_width):
    """The gap (cells) between the surfaces of b and ``other`` at slot s along b's
    outward unit ``normal``: the nearest particle of ``other`` minus the farthest of b,
    each widened by its half spacing (the particles' boxes, bounded by the box of their
    offsets: exact for faces normal to an axis, smaller than the true gap elsewhere)."""
    far_b, near_other, width = 0.0, 0.0, 0.0
    for d in range(3):
        nd = normal[d]
        if nd >= 0.0:
            far_b += nd * cext[s, b, d]
            near_other -= nd * cext[s, other, 3 + d]
        else:
            far_b -= nd * cext[s, b, 3 + d]
            near_other += nd * cext[s, other, d]
        width += abs(nd)
    return near_other - far_b - (half_width[b] + half_width[other]) * width


@njit(cache=True)
def release_open_gaps(slots, cext, cvol, release, half_width, m_tiny, block):
    """The release rule, after :func:`contact_start`: where the surfaces of a body and the
    heaviest other body at a contact node are more than ``release[b, other]`` cells apart
    (:func:`volume_gap` when ``cvol`` has the slots' rows, else :func:`surface_gap` from
    ``cext``), the body is not in contact there this step: its start velocity
    goes back to its own (Eq. 6, undoing method 2's Eq. 25) and its normal to zero, so
    that :func:`contact_end` applies no force (Eq. 12 needs an approach along a normal).
    Contact then pushes only across a closed gap, and bodies that part keep their
    momentum. Writes ``slots.cvel`` and ``slots.cnorm``."""
    cnodal, slot_nodes, cvel, cnorm, _, _ = slots
    faces = block.faces
    vec = np.empty(3)
    for s in range(slot_nodes.shape[0]):
        n = slot_nodes[s]
        for b in range(cnodal.shape[1]):
            m = cnodal[s, b, 0]
            if m <= m_tiny:
                continue
            other = _heaviest_other(cnodal, s, b, m_tiny)
            if other < 0:
                continue
            if cvol.shape[0]:
                gap = volume_gap(cvol, s, b, other, node_capacity(n, block))
            else:
                gap = surface_gap(cext, s, b, other, cnorm[s, b], half_width)
            if gap <= release[b, other]:
                continue
            for d in range(3):
                vec[d] = cnodal[s, b, 1 + d] / m
            constrain_coded(vec, faces[n])
            for d in range(3):
                cvel[s, b, d] = vec[d]
                cnorm[s, b, d] = 0.0


@njit(cache=True)
def contact_volumes(pts, volume, geo, slot_of, cvol, want, layers=None):
    """Each body's shape-function-weighted particle volume sum_p S_ip V_p at the contact
    nodes, in cells^3 (``volume``: the particles' volumes, initial under uGIMP:
    ``pmpm.solver.particle_bodies.ParticleBodies.gap_volumes``), for the volume gap
    (:func:`volume_gap`). With the hats (current volumes) it samples the integral of the
    node's trilinear hat over the body's material; under uGIMP (initial volumes) it is
    the hat's integral over the particles' undeformed domains, counted as often as they
    overlap, so a compressed body reads a little fuller than it is. With ``layers`` (a LayerSums over the slots, rows (n_slots,
    n_bodies)) the sums are layer-ordered (``pmpm.kernels.layered``)."""
    x, _, _, body, level = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)            # a compile-time constant: see pmpm.kernels.shape
    axes = np.empty((9, 3))
    order, count, axis, starts, halo, scratch, kept = unpack(layers, x.shape[0])
    acc, current, shift = cvol, NO_LAYER, 0
    if layers is not None:
        acc = scratch
    for i in range(count):
        p = point_at(layers, order, i)
        if level[p] != want:
            continue
        if layers is not None:
            layer = layer_plane(x, p, origin, inv_h, lo, axis)
            if layer != current:
                leave_layer(layer, current, cvol, acc, starts, halo, kept)
                current, shift = layer, starts[layer - halo]
        b, vp = body[p], volume[p] * inv_h ** 3
        base, reach = point_axes(x, p, origin, inv_h, lo, strides, shape, half_width[b], axes)
        for a in range(reach):
            for bb in range(reach):
                for cc in range(reach):
                    s = slot_of[base + a * strides[0] + bb * strides[1] + cc * strides[2]]
                    if s >= 0:
                        acc[s - shift, b] += vp * axes[0, a] * axes[3, bb] * axes[6, cc]
    if layers is not None:
        leave_layer(NO_LAYER, current, cvol, acc, starts, halo, kept)


@njit(cache=True, inline="always")
def _hat_depth(fraction):
    """Where a body's flat surface lies, in cells from the node along its outward normal,
    when it fills ``fraction`` of the node's hat (the inverse of the hat's running
    integral: (1 + s)^2 / 2 for s <= 0, 1 - (1 - s)^2 / 2 above)."""
    f = min(max(fraction, 0.0), 1.0)
    if f <= 0.5:
        return np.sqrt(2.0 * f) - 1.0
    return 1.0 - np.sqrt(2.0 * (1.0 - f))


@njit(cache=True, inline="always")
def node_capacity(n, block):
    """The integral of node n's hat over the grid box, in cells^3: 1 inside, 1/2 per
    axis on which the node lies on a face of the box. A node beyond a plane of symmetry
    (``pmpm.kernels.boundary.mirrors``) holds its image's volumes, and so its capacity."""
    capacity = 1.0
    for d in range(3):
        i = block.lo[d] + (n // block.strides[d]) % block.shape[d]
        top = block.n_cells[d]
        if i < 0 and mirrors(block.boundary[2 * d], block.friction[2 * d]):
            i = -i
        elif i > top and mirrors(block.boundary[2 * d + 1], block.friction[2 * d + 1]):
            i = 2 * top - i
        if i <= 0 or i >= top:
            capacity *= 0.5
    return capacity


@njit(cache=True, inline="always")
def volume_gap(cvol, s, b, other, capacity):
    """The gap (cells) between the surfaces of b and ``other`` at slot s from the share
    of the node's hat each body fills (``cvol`` in cells^3, ``capacity`` the node's):
    each body's surface is placed where a flat face normal to the line between them would
    fill that share (:func:`_hat_depth`). Touching flat faces give 0 at any distance from
    the node; unlike the particles' farthest reach it weighs the surfaces near the node,
    not the nearest point anywhere in its support, so a curved surface is not met early
    by the nodes beside the contact patch."""
    return -_hat_depth(cvol[s, other] / capacity) - _hat_depth(cvol[s, b] / capacity)
