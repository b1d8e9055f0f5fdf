"""The impulses the grid's constraints and grid contact give the material in a step,
for the force histories (``pmpm.solver.forces``).

What a node gives the particles that reach it in a step is, over the particles,
``m a dt + s (m v0 - p)``: ``m`` and ``p`` are the mass and momentum those particles
put on the node (before any reflection across a plane of symmetry), ``a`` the node's
acceleration and ``v0`` its start-of-step velocity, both after every correction, and
``s`` the share of the start velocity the transfer passes on (0 under FLIP, ``time.pic``
for a blend, 1 under APIC). Less the force ``f`` the particles' own stresses, gravity and
loads put there, ``f dt``, what remains is the impulse of whatever else acted at the
node: a face of the grid box (a fixed face, a slip face, a wall, a plane of symmetry),
or, for one body at a contact node, the other bodies. Away from faces and contact the
remainder is zero to round-off (``a = f / m``, ``v0 = p / m``).

The energy a constraint or contact dissipates in a step is the work of its impulses
against the motion they leave: ``-J . v`` summed over the bodies it pushed, ``v`` each
body's end-of-step velocity at the node (for contact, relative to the node's rigid body
or, without one, to its centre of mass; the faces of the box do not move). A contact that
leaves the bodies moving together in the normal (grid contact's correction, a surface
pair's stick impulse) and a fixed, slip or symmetry face do no such work; friction that
lets them slide does, mu |J_n| |v_slip|, which is LS-DYNA's sliding energy.
"""
import numpy as np
from numba import njit

from .boundary import FIXED, SLIP, UPPER, constrain_coded
from .contact import _heaviest_other
from .exact_sum import put2, put3

#: the width of one pair's record: impulse (3), normal impulse (compression positive),
#: tangential impulse (3), dissipated energy
PAIR_WIDTH = 8
#: the width of one face's record: impulse (3), dissipated energy
FACE_WIDTH = 4
#: the columns of the raw nodal rows kept for the face impulses: mass, momentum (3),
#: rigid mass, force (3)
RAW_WIDTH = 8


@njit(cache=True)
def face_zone(faces, pairs, counted, per_plane, nodes, face_of):
    """The nodes whose impulse a face of the box may carry: nodes with a face code
    (``faces``) and the nodes of the mirror ``pairs`` (beyond a plane of symmetry and
    their images), on the planes this rank counts (``counted[n // per_plane]``), each
    once. ``nodes`` and ``face_of`` (the mirror face, -1 for none) are filled; returns
    how many."""
    count = 0
    mirror_face = np.full(faces.shape[0], -1, np.int64)
    for k in range(pairs.shape[0]):
        for j in range(2):
            if mirror_face[pairs[k, j]] < 0:
                mirror_face[pairs[k, j]] = pairs[k, 2]
    for n in range(faces.shape[0]):
        if (faces[n] or mirror_face[n] >= 0) and counted[n // per_plane]:
            nodes[count] = n
            face_of[count] = mirror_face[n]
            count += 1
    return count


@njit(cache=True)
def keep_rows(nodes, count, array, first, out):
    """out[k, first:first + width] = array[nodes[k]] for the first ``count`` nodes."""
    for k in range(count):
        for c in range(array.shape[1]):
            out[k, first + c] = array[nodes[k], c]


@njit(cache=True, inline="always")
def _face_of_component(code, g, block, d, mirror_face):
    """The box face (2 axis + upper) that takes component d of a node's impulse (``g``:
    the node's global index): the face of axis d the node lies on or beyond; else a
    fixed face or a wall it lies on (their tangential pull); else the plane of symmetry
    it mirrors across; else its first face. So the tangential parts of a mirrored group
    of nodes (a node beyond a plane of symmetry and its image), which cancel, stay
    together on one face, even at a corner of two planes."""
    if g[d] <= 0 and block.boundary[2 * d] != 0:
        out = 2 * d
    elif g[d] >= block.n_cells[d] and block.boundary[2 * d + 1] != 0:
        out = 2 * d + 1
    else:
        first, fixed = -1, -1
        for e in range(3):
            kind = (code >> (2 * e)) & 3
            if kind == FIXED or kind == SLIP:
                face = 2 * e + ((code >> (UPPER + e)) & 1)
                if kind == FIXED and fixed < 0:
                    fixed = face
                if first < 0:
                    first = face
        out = fixed if fixed >= 0 else (mirror_face if mirror_face >= 0 else first)
    return out          # one exit (pmpm.fem.elements._block_forces says why)


@njit(cache=True)
def face_impulses(nodes, face_of, count, raw, gvel, gnew, block, share, dt, m_tiny, slave,
                  out):
    """Add each kept node's impulse from the faces (module docstring) to ``out[:, :3]``
    (6, :data:`FACE_WIDTH`), component by component to the face that takes it
    (:func:`_face_of_component`), and the work it dissipated (``-impulse . v`` with the
    node's end velocity ``v``) to ``out[:, 3]``.
    Nodes of rigid bodies (rigid mass > 0) and nodes without mass are left out: a rigid
    body's push is not a face's, and so are tied slaves (``slave[n]``: their motion is
    their masters', pmpm.kernels.tied). ``block``: the level's NodeBlock."""
    g = np.empty(3, np.int64)
    for k in range(count):
        m = raw[k, 0]
        n = nodes[k]
        if raw[k, 4] > 0.0 or m <= m_tiny or slave[n]:
            continue
        for d in range(3):
            g[d] = block.lo[d] + (n // block.strides[d]) % block.shape[d]
        for d in range(3):
            impulse = (m * gnew[n, 3 + d] - raw[k, 5 + d]) * dt
            impulse += share * (m * gvel[n, d] - raw[k, 1 + d])
            face = _face_of_component(block.faces[n], g, block, d, face_of[k])
            if face >= 0:
                put2(out, face, d, impulse)
                put2(out, face, 3, -(impulse * gnew[n, d]))


@njit(cache=True)
def contact_impulses(slots, real_mass, share, body_rigid, codes, counted, per_plane, dt,
                     m_tiny, slave, out):
    """Add to ``out[b, other]`` (n_bodies, n_bodies, :data:`PAIR_WIDTH`) the impulse grid
    contact gave each deformable body b at the contact nodes this rank counts, against
    the heaviest other body there (the one its correction was made against): the end
    correction ``m (a - a_alone) dt`` (``a_alone`` the body's own force over its mass,
    within the node's faces) and ``share[b]`` times method 2's start correction ``m (v0
    - v_alone)``, with ``m`` the mass its particles put on the node (``real_mass``,
    before any reflection). The normal part is taken along b's outward normal, counted
    positive when it pushes b inward. Tied slaves (``slave[n]``) are left out: their
    motion is their masters'. The work dissipated, ``-imp . (v_b - v_ref)`` with
    the end velocities (:func:`_reference_velocity`), goes to the same pair: against a
    rigid body it is the pair's; between two deformable bodies, whose impulses are
    opposite, the two terms add up to the pair's ``-imp . (v_b - v_other)``."""
    cnodal, slot_nodes, cvel, cnorm, cforce, cnew = slots
    imp, own, ref = np.empty(3), np.empty(3), np.empty(3)
    for s in range(slot_nodes.shape[0]):
        n = slot_nodes[s]
        if not counted[n // per_plane] or slave[n]:
            continue
        _reference_velocity(cnodal, cnew, body_rigid, s, ref)
        for b in range(cnodal.shape[1]):
            m, mr = cnodal[s, b, 0], real_mass[s, b]
            # a body below the contact's tiny mass takes the shared field's motion: its
            # points lose their own force there, which counts as the contact's push
            if m <= 0.0 or mr <= 0.0 or body_rigid[b]:
                continue
            other = _heaviest_other(cnodal, s, b, m_tiny)
            if other < 0:
                continue
            _body_impulse(cnodal, cvel, cforce, cnew, s, b, mr, share[b], codes[n], dt,
                          own, imp)
            add_pair(out, b, other, imp, cnorm[s, b])
            work = 0.0
            for d in range(3):
                work -= imp[d] * (cnew[s, b, d] - ref[d])
            put3(out, b, other, 7, work)


@njit(cache=True, inline="always")
def _reference_velocity(cnodal, cnew, body_rigid, s, ref):
    """ref = the end velocity a contact node's bodies slide against: its rigid bodies'
    (their mass-weighted mean), else its bodies' centre of mass."""
    mass, rigid_mass = 0.0, 0.0
    ref[:] = 0.0
    for c in range(cnodal.shape[1]):
        if body_rigid[c] and cnodal[s, c, 0] > 0.0:
            rigid_mass += cnodal[s, c, 0]
    for c in range(cnodal.shape[1]):
        m = cnodal[s, c, 0]
        if m <= 0.0 or (rigid_mass > 0.0 and not body_rigid[c]):
            continue
        mass += m
        for d in range(3):
            ref[d] += m * cnew[s, c, d]
    if mass > 0.0:
        for d in range(3):
            ref[d] /= mass


@njit(cache=True, inline="always")
def _body_impulse(cnodal, cvel, cforce, cnew, s, b, mr, share, code, dt, own, imp):
    """imp = the impulse grid contact gave body b at slot s (module docstring): ``mr``
    (a - a_alone) dt + ``share`` mr (v0 - v_alone), the body's own acceleration and
    velocity within the node's face code ``code``; ``own`` is scratch."""
    m = cnodal[s, b, 0]
    for d in range(3):
        own[d] = cforce[s, b, d] / m
    constrain_coded(own, code)
    for d in range(3):
        imp[d] = mr * (cnew[s, b, 3 + d] - own[d]) * dt
    if share > 0.0:
        for d in range(3):
            own[d] = cnodal[s, b, 1 + d] / m
        constrain_coded(own, code)
        for d in range(3):
            imp[d] += share * mr * (cvel[s, b, d] - own[d])


@njit(cache=True)
def rigid_partner_impulses(slots, real_mass, share, body_rigid, free, codes, counted,
                           per_plane, dt, out):
    """Add to ``out[r]`` (n_bodies, 3; or an exact accumulator of that shape,
    pmpm.kernels.exact_sum) the impulse grid contact gave the other bodies
    at the contact nodes this rank counts where the rigid body r has mass, for the
    bodies r that ``free`` marks (free rigid particle bodies, pmpm.solver.
    rigid_particles). A node that rigid bodies reach takes their velocity (their
    mass-weighted mean, pmpm.kernels.mpm.nodal_velocities), and every other body there
    is corrected against it, whichever body is its heaviest other: so the sum of their
    impulses (:func:`_body_impulse`, each with the mass its own points put on the node,
    ``real_mass``) is what the rigid bodies gave, shared among them by their masses at
    the node. The other bodies' impulses are those :func:`contact_impulses` counts, and
    also those of a body with a mass below the contact's threshold there: its points take
    the rigid velocity and no acceleration, so they lose their own force (a particle at
    the edge of a node's reach puts little mass on it, but not little force: 1e-11 of
    the falling blocks' momentum in tests/test_rigid_free_particles.py)."""
    cnodal, slot_nodes, cvel, _, cforce, cnew = slots
    imp, own, total = np.empty(3), np.empty(3), np.empty(3)
    for s in range(slot_nodes.shape[0]):
        n = slot_nodes[s]
        if not counted[n // per_plane]:
            continue
        rigid_mass, freed = 0.0, False
        for c in range(cnodal.shape[1]):
            if body_rigid[c] and cnodal[s, c, 0] > 0.0:
                rigid_mass += cnodal[s, c, 0]
                freed = freed or free[c]
        if not freed:
            continue
        total[:] = 0.0
        for b in range(cnodal.shape[1]):
            m, mr = cnodal[s, b, 0], real_mass[s, b]
            if m <= 0.0 or mr <= 0.0 or body_rigid[b]:
                continue
            _body_impulse(cnodal, cvel, cforce, cnew, s, b, mr, share[b], codes[n], dt,
                          own, imp)
            for d in range(3):
                total[d] += imp[d]
        for r in range(cnodal.shape[1]):
            if free[r] and body_rigid[r] and cnodal[s, r, 0] > 0.0:
                weight = cnodal[s, r, 0] / rigid_mass
                for d in range(3):
                    put2(out, r, d, weight * total[d])


@njit(cache=True, inline="always")
def add_pair(out, b, other, imp, normal):
    """out[b, other] += the impulse ``imp`` on b, its normal part along b's outward
    ``normal`` (positive pushing inward) and its tangential rest."""
    along = imp[0] * normal[0] + imp[1] * normal[1] + imp[2] * normal[2]
    for d in range(3):
        put3(out, b, other, d, imp[d])
        put3(out, b, other, 4 + d, imp[d] - along * normal[d])
    put3(out, b, other, 3, -along)


@njit(cache=True)
def pair_impulses(first, second, impulses, normals, work, out):
    """For surface and node-to-surface contact: pair k gave body ``first[k]`` the impulse
    ``-impulses[k]`` and body ``second[k]`` ``+impulses[k]``; ``normals[k]`` is the
    face's outward normal (the face belongs to ``second[k]``); ``work[k]`` the energy
    it dissipated (:func:`surface_pair_work`), half to each direction of the pair."""
    imp, normal = np.empty(3), np.empty(3)
    for k in range(impulses.shape[0]):
        put3(out, first[k], second[k], 7, 0.5 * work[k])
        put3(out, second[k], first[k], 7, 0.5 * work[k])
        for d in range(3):
            imp[d] = -impulses[k, d]
            normal[d] = -normals[k, d]          # the first body's outward normal
        add_pair(out, first[k], second[k], imp, normal)
        for d in range(3):
            imp[d] = impulses[k, d]
            normal[d] = normals[k, d]
        add_pair(out, second[k], first[k], imp, normal)


def surface_pair_work(impulses, relative, inverse_mass):
    """The energy each surface pair's impulse dissipated: ``I . u'`` with ``u' = u - I /
    m`` the relative velocity it leaves (``u``: the first body's velocity less the face
    point's before the impulse, ``I``: the impulse on the face point, ``1/m``: the pair's
    inverse mass, ``inverse_mass``). Zero for a stick impulse (``u' = 0``); mu |I_n|
    |u'_t| while sliding under Coulomb's cap."""
    after = relative - impulses * inverse_mass[:, None]
    return np.einsum("kd,kd->k", impulses, after)
