"""Particle-to-surface contact (ICFEMP, seed 004 Sec. 3): the loops over particles and
master segments (bilinear faces of FE elements), free of MPI and of the case.

* ``bucket_segments``: the global search's buckets (Eqs. 33-35), each segment entered in
  every bucket its inflated bounding box overlaps;
* ``closest_point``: the local search (Eqs. 36-41), the closest point of a bilinear face by
  Newton, its outward unit normal and the gap;
* ``find_pairs``: per particle its nearest segment, among those of its buckets, that it
  touches or has got behind in the step (``segment_moves``: how far each face moved);
* ``pair_impulses``: per pair the stick impulse with Coulomb's cap (Eqs. 42-53);
* the particle side on its body's grid (issue 24 Sec. 4): ``surface_nodes`` (a pair's
  nodes between its particle and the face), ``node_pair_impulses`` (their stick
  impulses), ``nodal_velocity_changes`` and ``take_velocity_changes`` (the nodes'
  changes, and the particles that read them taking them), ``gather_from_nodes``.

A face's nodes 0-3 sit at (xi, eta) = (-1,-1), (1,-1), (1,1), (-1,1), counter-clockwise
seen from outside (pmpm.fem.hexahedron.FACES), so r_xi x r_eta points out of the body.
"""
import numpy as np
from numba import njit

from .boundary import constrain_velocity
from .shape import LINEAR, MAX_NODES, weights


XI = np.array([-1.0, 1.0, 1.0, -1.0])
ETA = np.array([-1.0, -1.0, 1.0, 1.0])
NEWTON_STEPS = 25


@njit(cache=True)
def face_shapes(xi, eta, phi):
    """phi_J = (1 + xi_J xi)(1 + eta_J eta) / 4 (Eq. 37)."""
    for j in range(4):
        phi[j] = 0.25 * (1.0 + XI[j] * xi) * (1.0 + ETA[j] * eta)


@njit(cache=True, inline="always")
def face_frame(xf, xi, eta):
    """r(xi, eta) (Eq. 36) and its two tangents r_xi, r_eta, as a 9-tuple of scalars
    (no arrays to allocate in the Newton loop of ``closest_point``)."""
    r0 = r1 = r2 = a0 = a1 = a2 = b0 = b1 = b2 = 0.0
    for j in range(4):
        phi = 0.25 * (1.0 + XI[j] * xi) * (1.0 + ETA[j] * eta)
        along_xi = 0.25 * XI[j] * (1.0 + ETA[j] * eta)
        along_eta = 0.25 * ETA[j] * (1.0 + XI[j] * xi)
        x0, x1, x2 = xf[j, 0], xf[j, 1], xf[j, 2]
        r0 += phi * x0
        r1 += phi * x1
        r2 += phi * x2
        a0 += along_xi * x0
        a1 += along_xi * x1
        a2 += along_xi * x2
        b0 += along_eta * x0
        b1 += along_eta * x1
        b2 += along_eta * x2
    return r0, r1, r2, a0, a1, a2, b0, b1, b2


@njit(cache=True)
def closest_point(xf, t, out):
    """The point of the bilinear face ``xf`` (4, 3) closest to ``t`` (Eqs. 38-39:
    r_xi.(t - r) = r_eta.(t - r) = 0 by Newton from the centre, the iterate kept within
    [-1, 1]^2, so that a point beyond an edge lands on the edge). Fills ``out`` with xi,
    eta, the outward unit normal at that point (Eq. 41) and returns the gap
    g = n.(t - r_c) (Eq. 40) and the in-plane distance of t from r_c. In scalars (the
    search calls it thousands of times a step); each sum in a fixed order."""
    t0, t1, t2 = t[0], t[1], t[2]
    c0 = 0.25 * (xf[0, 0] - xf[1, 0] + xf[2, 0] - xf[3, 0])
    c1 = 0.25 * (xf[0, 1] - xf[1, 1] + xf[2, 1] - xf[3, 1])
    c2 = 0.25 * (xf[0, 2] - xf[1, 2] + xf[2, 2] - xf[3, 2])
    xi = eta = 0.0
    for _ in range(NEWTON_STEPS):
        r0, r1, r2, a0, a1, a2, b0, b1, b2 = face_frame(xf, xi, eta)
        e0, e1, e2 = t0 - r0, t1 - r1, t2 - r2
        f0 = 0.0 + a0 * e0 + a1 * e1 + a2 * e2
        f1 = 0.0 + b0 * e0 + b1 * e1 + b2 * e2
        a00 = 0.0 + a0 * a0 + a1 * a1 + a2 * a2
        a11 = 0.0 + b0 * b0 + b1 * b1 + b2 * b2
        a01 = 0.0 + (a0 * b0 - c0 * e0)
        a01 += a1 * b1 - c1 * e1
        a01 += a2 * b2 - c2 * e2
        det = a00 * a11 - a01 * a01
        if det <= 0.0:                 # far from a strongly warped face: plain gradient
            det, a01 = a00 * a11, 0.0
        dxi = (a11 * f0 - a01 * f1) / det
        deta = (a00 * f1 - a01 * f0) / det
        new_xi = min(1.0, max(-1.0, xi + dxi))
        new_eta = min(1.0, max(-1.0, eta + deta))
        moved = abs(new_xi - xi) + abs(new_eta - eta)
        xi, eta = new_xi, new_eta
        if moved < 1e-13:
            break
    r0, r1, r2, a0, a1, a2, b0, b1, b2 = face_frame(xf, xi, eta)
    n0 = a1 * b2 - a2 * b1
    n1 = a2 * b0 - a0 * b2
    n2 = a0 * b1 - a1 * b0
    norm = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    n0, n1, n2 = n0 / norm, n1 / norm, n2 / norm
    e0, e1, e2 = t0 - r0, t1 - r1, t2 - r2
    g = n0 * e0 + n1 * e1 + n2 * e2
    s0, s1, s2 = e0 - g * n0, e1 - g * n1, e2 - g * n2
    out[0], out[1], out[2], out[3], out[4] = xi, eta, n0, n1, n2
    return g, np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)


@njit(cache=True)
def bucket_of(x, lo, inv_size, dims):
    """Eqs. 33-35: the bucket index of ``x``, -1 outside the bucket box."""
    index = 0
    for d in (2, 1, 0):
        c = int(np.floor((x[d] - lo[d]) * inv_size))
        if c < 0 or c >= dims[d]:
            return -1
        index = index * dims[d] + c
    return index


@njit(cache=True)
def bucket_range(seg_lo, seg_hi, s, lo, inv_size, dims, c0, c1):
    """The first and last bucket along each axis that segment s's box overlaps."""
    for d in range(3):
        c0[d] = max(0, int(np.floor((seg_lo[s, d] - lo[d]) * inv_size)))
        c1[d] = min(dims[d] - 1, int(np.floor((seg_hi[s, d] - lo[d]) * inv_size)))


@njit(cache=True)
def bucket_segments(seg_lo, seg_hi, lo, inv_size, dims):
    """CSR lists (start, items) of the segments of every bucket: a segment is entered in
    each bucket its box [seg_lo, seg_hi] (already inflated) overlaps."""
    n_buckets = dims[0] * dims[1] * dims[2]
    start = np.zeros(n_buckets + 1, np.int64)
    c0, c1 = np.empty(3, np.int64), np.empty(3, np.int64)
    for s in range(len(seg_lo)):
        bucket_range(seg_lo, seg_hi, s, lo, inv_size, dims, c0, c1)
        for k in range(c0[2], c1[2] + 1):
            for j in range(c0[1], c1[1] + 1):
                for i in range(c0[0], c1[0] + 1):
                    start[(k * dims[1] + j) * dims[0] + i + 1] += 1
    for b in range(n_buckets):
        start[b + 1] += start[b]
    items = np.empty(start[n_buckets], np.int64)
    fill = start[:n_buckets].copy()
    for s in range(len(seg_lo)):
        bucket_range(seg_lo, seg_hi, s, lo, inv_size, dims, c0, c1)
        for k in range(c0[2], c1[2] + 1):
            for j in range(c0[1], c1[1] + 1):
                for i in range(c0[0], c1[0] + 1):
                    b = (k * dims[1] + j) * dims[0] + i
                    items[fill[b]] = s
                    fill[b] += 1
    return start, items


#: squared distances closer than this times the particle radius squared are a tie
TIE = 1e-9


@njit(cache=True, inline="always")
def nearer(dist, key, best, best_key, tie):
    """Whether a candidate at squared distance ``dist`` beats the best so far. Faces as
    near as each other to within ``tie`` (a point on a symmetry plane of the mesh) tie,
    and the tie goes to the smaller key: the last bits of the positions, which differ
    between rank counts, do not pick the face."""
    return dist < best - tie or (dist <= best + tie and key < best_key)


#: the relative slack of the box cull (``beyond_reach``): round-off of the closest point
#: and of the box is far below it, so a culled segment could never have passed the tests
CULL_SLACK = 1e-9


@njit(cache=True, inline="always")
def beyond_reach(xf, t, reach):
    """Whether point ``t`` lies farther than ``reach`` from the box of face ``xf``'s four
    nodes. The face's closest point to ``t`` is a convex combination of the nodes
    (bilinear weights at (xi, eta) in [-1, 1]^2), so it lies in that box: a face for
    which this is true is farther than ``reach`` from ``t``, and the Newton iteration of
    ``closest_point`` need not run for it. The slack (CULL_SLACK of ``reach`` and of
    |t|) keeps the test on the safe side of round-off."""
    far, size = 0.0, 0.0
    for d in range(3):
        lo = hi = xf[0, d]
        for j in range(1, 4):
            lo = min(lo, xf[j, d])
            hi = max(hi, xf[j, d])
        excess = max(0.0, lo - t[d], t[d] - hi)
        far += excess * excess
        size = max(size, abs(t[d]))
    slack = reach + CULL_SLACK * (reach + size)
    return far > slack * slack


@njit(cache=True)
def gather_segments(x, x0, v, nodes, seg_x, seg_x0, seg_v):
    """``seg_x[s, j] = x[nodes[s, j]]`` and likewise x0 and v: the segments' node
    states in one pass (numpy's fancy indexing does it in three, more slowly)."""
    for s in range(len(nodes)):
        for j in range(4):
            i = nodes[s, j]
            for d in range(3):
                seg_x[s, j, d] = x[i, d]
                seg_x0[s, j, d] = x0[i, d]
                seg_v[s, j, d] = v[i, d]


@njit(cache=True)
def box_bounds(seg_lo, seg_hi, lo, hi):
    """``lo``, ``hi`` (3): the smallest of ``seg_lo`` and the largest of ``seg_hi`` per
    axis (numpy's reductions along the long axis of an (n, 3) array are slow)."""
    for d in range(3):
        lo[d], hi[d] = np.inf, -np.inf
    for s in range(len(seg_lo)):
        for d in range(3):
            lo[d] = min(lo[d], seg_lo[s, d])
            hi[d] = max(hi[d], seg_hi[s, d])


@njit(cache=True)
def body_box_bounds(lo, hi, body, boxes):
    """``boxes`` (n_bodies, 2, 3), filled with empty boxes (inf, -inf) by the caller:
    per body the smallest of ``lo`` and the largest of ``hi`` over its rows (``body``
    int64), one pass (the contacts' halo, pmpm.solver.contact_halo)."""
    for s in range(len(lo)):
        b = body[s]
        for d in range(3):
            boxes[b, 0, d] = min(boxes[b, 0, d], lo[s, d])
            boxes[b, 1, d] = max(boxes[b, 1, d], hi[s, d])


@njit(cache=True)
def mark_rows_meeting(lo, hi, body, master, box, going):
    """``going[s]`` set where row s is of body ``master`` and its box [lo, hi] meets
    ``box`` (2, 3), closed; rows already marked stay marked."""
    for s in range(len(lo)):
        if going[s] or body[s] != master:
            continue
        meets = True
        for d in range(3):
            if hi[s, d] < box[0, d] or lo[s, d] > box[1, d]:
                meets = False
        if meets:
            going[s] = True


@njit(cache=True)
def point_moves(x, x0, idx, moves):
    """``moves[k]``: how far point ``idx[k]`` moved from its ``x0`` (the sum of squares
    in numpy's order for a row norm, so the same bits)."""
    for k in range(len(idx)):
        i = idx[k]
        d0, d1, d2 = x[i, 0] - x0[i, 0], x[i, 1] - x0[i, 1], x[i, 2] - x0[i, 2]
        moves[k] = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@njit(cache=True)
def segment_moves(seg_x, seg_x0, moves):
    """``moves[s]``: the farthest any node of segment s moved in the step (from its
    start-of-step positions ``seg_x0``)."""
    for s in range(len(seg_x)):
        far = 0.0
        for j in range(4):
            d2 = 0.0
            for d in range(3):
                d2 += (seg_x[s, j, d] - seg_x0[s, j, d]) ** 2
            far = max(far, d2)
        moves[s] = np.sqrt(far)


@njit(cache=True)
def find_pairs(px, px0, pbody, vol0, moved, seg_x, seg_x0, seg_move, seg_body, seg_key,
               touches, lo, inv_size, dims, start, items, pair_seg, pair_geo):
    """Per particle p its segment: among the segments of its bucket whose body it
    ``touches[pbody, seg_body]``, those it is in contact with: g < r (the particle a
    sphere of half its spacing, r = vol0[p]^(1/3) / 2, the C library's cube root, taken
    only for a particle whose bucket holds a face it meets), the closest point at most r
    from the foot of the normal (so a particle beside an edge meets the side face), and a
    centre that was on this face's side at the start of the step and has not gone through:

    * g > -(r + moved[p] + seg_move[s]): the centre is at most as deep behind the face as
      its radius plus how far it (``moved[p]``) and the face (``seg_move[s]``) moved in
      the step. A centre that was out (or within its radius) at the start cannot skip
      this window in one step, however fast it went;
    * g0 > -r, g0 the gap of the start-of-step centre ``px0`` from the
      start-of-step face ``seg_x0``: the centre was not deeper than its radius behind the
      face before the step. This rules out the far faces of the body, and a face that a
      centre crossing a thin body reaches from behind: it is not pulled through to the
      wrong side.

    Of those the nearest, ties (within TIE of radius^2) to the smaller segment key (the
    same on any rank count).
    ``pair_seg[p]``: the segment index or -1; ``pair_geo[p]``: xi, eta, n (3), g.
    Returns the number of pairs."""
    out, before = np.empty(5), np.empty(5)
    n_pairs = 0
    for p in range(len(px)):
        pair_seg[p] = -1
        b = bucket_of(px[p], lo, inv_size, dims)
        if b < 0:
            continue
        best, best_key, best_reach = np.inf, -1, np.inf
        radius = depth = -1.0
        for k in range(start[b], start[b + 1]):
            s = items[k]
            if not touches[pbody[p], seg_body[s]]:
                continue
            if radius < 0.0:
                radius = 0.5 * np.cbrt(vol0[p])
                depth = radius + moved[p]
            # a pair's centre lies within sqrt((depth + seg_move)^2 + radius^2) of its
            # closest point, and one that beats the best within sqrt(best + tie): no
            # farther than either from the face's box
            if beyond_reach(seg_x[s], px[p],
                            min(radius + depth + seg_move[s], best_reach)):
                continue
            g, off = closest_point(seg_x[s], px[p], out)
            if g >= radius or g <= -(depth + seg_move[s]) or off > radius:
                continue
            dist = g * g + off * off
            if not nearer(dist, seg_key[s], best, best_key, TIE * radius * radius):
                continue
            g0, _ = closest_point(seg_x0[s], px0[p], before)
            if g0 <= -radius:
                continue
            best, best_key = dist, seg_key[s]
            best_reach = np.sqrt(best + TIE * radius * radius)
            pair_seg[p] = s
            for c in range(5):
                pair_geo[p, c] = out[c]
            pair_geo[p, 5] = g
        if pair_seg[p] >= 0:
            n_pairs += 1
    return n_pairs


@njit(cache=True)
def pair_impulse(m_p, v_p, v_nodes, lent_inv_m, phi, n, mu, impulse):
    """The impulse I_c = f_c dt on the contact point C of one pair (the particle takes
    -I_c). Stick (Eqs. 42, 44, 47 with f_p = -f_c): v_p + dt f_p/m_p = v_c + dt f_c/m_c
    gives f_c dt = m_p m_c (v̄_p - v̄_c)/(m_p + m_c), v̄_c = sum phi_J v̄_J (Eq. 45),
    1/m_c = sum phi_J^2 / m_J^k (Eq. 49) with m_J^k the part of node J's mass lent to
    this pair: ``lent_inv_m`` [J] = phi_J / m_J^k (phi_J / m_J for a pair alone on its
    nodes, which is Eq. 49; 0 for a rigid or held node).
    Split along n (Eqs. 50-51), tangent capped at mu |normal| (Eq. 52). Nothing when the
    pair separates, (v̄_p - v̄_c).n >= 0. Returns whether an impulse acts."""
    inv_mc = 0.0
    for j in range(4):
        inv_mc += phi[j] * lent_inv_m[j]
    rel = np.empty(3)
    for d in range(3):
        vc = 0.0
        for j in range(4):
            vc += phi[j] * v_nodes[j, d]
        rel[d] = v_p[d] - vc
    approach = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2]
    if approach >= 0.0:
        impulse[:] = 0.0
        return False
    scale = m_p / (1.0 + m_p * inv_mc)            # m_p m_c / (m_p + m_c)
    normal = scale * approach
    tangent_norm = 0.0
    for d in range(3):
        impulse[d] = scale * (rel[d] - approach * n[d])
        tangent_norm += impulse[d] * impulse[d]
    tangent_norm = np.sqrt(tangent_norm)
    cap = mu * abs(normal)
    factor = cap / tangent_norm if tangent_norm > cap else 1.0
    for d in range(3):
        impulse[d] = normal * n[d] + factor * impulse[d]
    return True


@njit(cache=True)
def pair_impulses(pair_p, pair_s, pair_geo, mass, v, pbody, seg_v, seg_inv_m, seg_body,
                  friction, impulses):
    """``impulses[k]`` (3): the impulse on C of pair k (particle ``pair_p[k]``, segment
    ``pair_s[k]``); zero for a separating pair. ``seg_inv_m`` (ns, 4): per segment node
    Phi_J / m_J, the inverse of the mass node J lends a pair per unit of its phi_J."""
    phi = np.empty(4)
    for k in range(len(pair_p)):
        p, s = pair_p[k], pair_s[k]
        face_shapes(pair_geo[k, 0], pair_geo[k, 1], phi)
        pair_impulse(mass[p], v[p], seg_v[s], seg_inv_m[s], phi, pair_geo[k, 2:5],
                     friction[pbody[p], seg_body[s]], impulses[k])


# -- the particle side on the grid (issue 24 Sec. 4) ------------------------------------
@njit(cache=True, inline="always")
def node_offset(x, p, origin, inv_h, shape, axes, k, e):
    """e = (x_I - x_p) / h for the k-th node of particle p's stencil (the order of
    pmpm.kernels.shape.weights; ``axes`` as that left it)."""
    if shape == LINEAR:
        a, b, c = k // 4, (k // 2) % 2, k % 2
        t0 = (x[p, 0] - origin[0]) * inv_h
        t1 = (x[p, 1] - origin[1]) * inv_h
        t2 = (x[p, 2] - origin[2]) * inv_h
        e[0] = a - (t0 - np.floor(t0))
        e[1] = b - (t1 - np.floor(t1))
        e[2] = c - (t2 - np.floor(t2))
        return
    a, b, c = k // 9, (k // 3) % 3, k % 3
    e[0], e[1], e[2] = -axes[2, a], -axes[5, b], -axes[8, c]


@njit(cache=True)
def surface_nodes(x, idx, body, normals, geo, node, pair, weight):
    """The nodes of pair k (particle p = ``idx[k]``, normal ``normals[k]`` out of the
    face) that stand for the particle body's surface there: the nodes the particle
    reads (``x`` the positions the step's transfers used; ``geo`` the level's
    GridGeometry), each weighted by N_Ip times a ramp of its height over the particle
    along n across the particle's width, clamp(1/2 - (x_I - x_p).n / (2 lp h), 0, 1)
    (lp the body's half-width in cells, ``half_width``): 1 for the nodes lp h or more
    nearer the face than the particle, 0 for those lp h or more farther, linear between;
    renormalised to sum to 1 (all nodes at N_Ip when every ramp is 0). The ramp keeps
    the weights continuous as the particle crosses a node plane. With a step (a node
    counted while at or below the particle) the plane under a pressed layer stopped
    standing for the surface at once as the layer passed it, and the layer was crushed
    (the sphere on the FEM block gained 24 % of its energy at 0.25 mm and 72 % at 1 mm
    and 150 m/s). Fills rows (``node``, ``pair`` = k, ``weight``) and returns how many."""
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)
    nodes, axes, w = np.empty(MAX_NODES, np.int64), np.empty((9, 3)), np.empty(MAX_NODES)
    side, e = np.empty(MAX_NODES), np.empty(3)
    rows = 0
    for k in range(len(idx)):
        p = idx[k]
        n0, n1, n2 = normals[k, 0], normals[k, 1], normals[k, 2]
        reach = weights(x, p, origin, inv_h, lo, strides, shape, half_width[body[p]], axes,
                        nodes, w)
        inv_width = 0.5 / half_width[body[p]]     # the ramp spans the particle's width
        kept = 0.0
        for j in range(reach):
            node_offset(x, p, origin, inv_h, shape, axes, j, e)
            out = e[0] * n0 + e[1] * n1 + e[2] * n2
            side[j] = w[j] * min(1.0, max(0.0, 0.5 - out * inv_width))
            kept += side[j]
        if kept <= 0.0:                 # no node on the face's side: all of them
            side[:reach] = w[:reach]
            kept = 1.0
        for j in range(reach):
            if side[j] > 0.0:
                node[rows], pair[rows], weight[rows] = nodes[j], k, side[j] / kept
                rows += 1
    return rows


@njit(cache=True)
def node_pair_impulses(node, pair, weight, node_mass, node_share, node_v, pair_s, geo,
                       seg_v, seg_inv_m, friction, impulses):
    """``impulses[r]``: the impulse of row r (node I = ``node[r]`` of pair k =
    ``pair[r]``, weight W = ``weight[r]``) on the face point C of pair k, node I taking
    minus it: the stick impulse (pair_impulse) between node I, lent W m_I / S_I
    (S_I = ``node_share[I]``, the sum of W over the pairs on I), at its new velocity
    v_I, and pair k's face, lent W of what it lends the pair (the rows of a pair
    together take the pair's share): W times the stick impulse of m_I / S_I and the
    pair's face. Zero where node I separates from C, is empty or rigid (m_I = 0).
    ``geo`` (k, 6): xi, eta, n, g per pair; ``friction[k]`` its Coulomb coefficient;
    ``seg_inv_m`` [s] what the nodes of segment ``pair_s[k]`` lend (pair_impulses)."""
    phi, out = np.empty(4), np.empty(3)
    for r in range(len(node)):
        i, k, wr = node[r], pair[r], weight[r]
        m, share = node_mass[i], node_share[i]
        if m <= 0.0 or share <= 0.0 or wr <= 0.0:
            impulses[r, 0] = impulses[r, 1] = impulses[r, 2] = 0.0
            continue
        face_shapes(geo[k, 0], geo[k, 1], phi)
        s = pair_s[k]
        pair_impulse(m / share, node_v[i], seg_v[s], seg_inv_m[s], phi, geo[k, 2:5],
                     friction[k], out)
        for d in range(3):
            impulses[r, d] = wr * out[d]


@njit(cache=True)
def gather_from_nodes(x, idx, body, geo, field, out):
    """``out[k] = sum_I N_I(x_p) field[I]``, p = ``idx[k]``: a nodal field where the
    particle reads it."""
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)
    nodes, axes, w = np.empty(MAX_NODES, np.int64), np.empty((9, 3)), np.empty(MAX_NODES)
    for k in range(len(idx)):
        p = idx[k]
        reach = weights(x, p, origin, inv_h, lo, strides, shape, half_width[body[p]], axes,
                        nodes, w)
        for c in range(field.shape[1]):
            out[k, c] = 0.0
        for j in range(reach):
            for c in range(field.shape[1]):
                out[k, c] += w[j] * field[nodes[j], c]


@njit(cache=True)
def nodal_velocity_changes(nodal, impulse, gnew, faces, friction, dv):
    """``dv[I]``: the velocity change the nodal impulse ``impulse[I]`` gives node I of
    mass ``nodal[I, 0]``, after the grid's fixed and slip faces (applied to the node's
    new velocity ``gnew[I, :3]`` so that walls stop only motion into them); none at
    empty nodes and nodes that carry a rigid body (their velocity is imposed). Returns
    whether any node changes."""
    vec = np.empty(3)
    moved = False
    for n in range(len(dv)):
        m = nodal[n, 0]
        if nodal[n, 4] > 0.0 or m <= 0.0 or (impulse[n, 0] == 0.0 and impulse[n, 1] == 0.0
                                             and impulse[n, 2] == 0.0):
            dv[n, 0] = dv[n, 1] = dv[n, 2] = 0.0
            continue
        for d in range(3):
            vec[d] = gnew[n, d] + impulse[n, d] / m
        if faces[n]:
            constrain_velocity(vec, faces[n], friction)
        for d in range(3):
            dv[n, d] = vec[d] - gnew[n, d]
        moved = True
    return moved


@njit(cache=True)
def take_velocity_changes(x0, x, v, body, level, rigid, want, geo, dv, near, dt,
                          affine=None):
    """Every deformable particle of level ``want`` takes the nodal velocity changes
    ``dv`` as its grid-to-particle update would have: v += sum_I N_I(x0_p) dv_I and
    x += dt times that (``x0`` the start-of-step positions the transfer used); with
    ``affine`` (APIC) also A_p += sum_I N_I dv_I (x_I - x_p)^T / h^2 (h^2 A_p's scale,
    as pmpm.kernels.mpm gathers it). ``near[I]``: a node within one node of a changed
    one; a particle whose nearest node is not near reads no changed node (every shape
    reaches at most one node beyond its nearest) and is passed over."""
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)
    nodes, axes, w = np.empty(MAX_NODES, np.int64), np.empty((9, 3)), np.empty(MAX_NODES)
    e = np.empty(3)
    for p in range(len(x)):
        if level[p] != want or rigid[body[p]]:
            continue
        nearest = 0
        for d in range(3):
            c = np.int64(np.floor((x0[p, d] - origin[d]) * inv_h + 0.5))
            nearest += (c - lo[d]) * strides[d]
        if not near[nearest]:
            continue
        reach = weights(x0, p, origin, inv_h, lo, strides, shape, half_width[body[p]],
                        axes, nodes, w)
        d0 = d1 = d2 = 0.0
        for j in range(reach):
            n, wj = nodes[j], w[j]
            if dv[n, 0] == 0.0 and dv[n, 1] == 0.0 and dv[n, 2] == 0.0:
                continue
            d0 += wj * dv[n, 0]
            d1 += wj * dv[n, 1]
            d2 += wj * dv[n, 2]
            if affine is not None:
                node_offset(x0, p, origin, inv_h, shape, axes, j, e)
                for c in range(3):
                    affine[p, c] += wj * dv[n, 0] * e[c] * inv_h
                    affine[p, 3 + c] += wj * dv[n, 1] * e[c] * inv_h
                    affine[p, 6 + c] += wj * dv[n, 2] * e[c] * inv_h
        v[p, 0] += d0
        v[p, 1] += d1
        v[p, 2] += d2
        x[p, 0] += dt * d0
        x[p, 1] += dt * d1
        x[p, 2] += dt * d2
