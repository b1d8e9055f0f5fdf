"""Node-to-surface contact between FEM bodies: the loops over slave FE nodes and master
segments (bilinear free faces), free of MPI and of the case. The search and the face
geometry are particle-to-surface contact's (pmpm.kernels.surface_contact:
``bucket_segments``, ``bucket_of``, ``closest_point``, ``face_shapes``).

* ``find_node_pairs``: per slave node the nearest master face it has crossed at the
  trial positions (gap g < 0, its foot inside the face, at most the face's ``depth`` in
  plus what node and face moved in the step, on the face's side at the step's start);
* ``node_pair_impulses``: per pair the impulse that lands the node on the face, with
  Coulomb's cap on the tangential part.

Unlike a particle (a sphere of half its spacing, kept out of the face) a node is a point
on its body's surface: its pair acts only once the trial step has taken it through the
face, and then only as far as it takes to put it back on the face (or to stop the
approach, whichever is less), so that bodies meet where their surfaces meet.
"""
import numpy as np
from numba import njit

from .surface_contact import (TIE, beyond_reach, bucket_of, closest_point,
                             face_shapes, nearer)


@njit(cache=True)
def segment_boxes(seg_x, pad, seg_lo, seg_hi):
    """Each segment's box, grown by its ``pad``: ``seg_lo``, ``seg_hi`` (ns, 3) (the
    reductions over (ns, 4, 3) that numpy does slowly, along the short axis)."""
    for s in range(len(seg_x)):
        for d in range(3):
            lo = hi = seg_x[s, 0, d]
            for j in range(1, 4):
                lo = min(lo, seg_x[s, j, d])
                hi = max(hi, seg_x[s, j, d])
            seg_lo[s, d] = lo - pad[s]
            seg_hi[s, d] = hi + pad[s]


@njit(cache=True)
def find_node_pairs(nx, nx0, nmove, nbody, seg_x, seg_x0, seg_move, seg_body, seg_key,
                    seg_depth, touches, tol, lo, inv_size, dims, start, items, pair_seg,
                    pair_geo):
    """Per slave node n (trial positions ``nx``, start-of-step positions ``nx0``, bodies
    ``nbody``) its segment: among the segments of its bucket whose body it
    ``touches[nbody, seg_body]``, those it has crossed, g < -tol, with its closest point
    at most ``tol`` from the foot of the normal (inside the face), approaching or not,
    and on this face's side before the step:

    * g > -(seg_depth[s] + nmove[n] + seg_move[s]): at most the face's depth plus what
      the node and the face moved in the step behind it, so a node that was on the face
      at the start cannot skip the window in one step however fast it went;
    * g0 > -seg_depth[s], g0 the gap of ``nx0`` from the start-of-step face ``seg_x0``:
      the node was within the face's depth of it before the step, which rules out the
      far faces of the body and a face that a node crossing a thin body reaches from
      behind (it is not pulled through to the wrong side).

    Of those the nearest, ties to the smaller segment key (the same on any rank count),
    unless a face the node has not crossed, tol < g < seg_depth[s] with its foot inside,
    is nearer still: then the node is outside that face's element, on the surface of the
    other body, and no pair is made (a node on the bottom edge of a block lies inside the
    plane of the block's side faces, by up to their width, without being in the block;
    the approach test used to keep such nodes off, and does not since a node that does
    not approach is also corrected). A node on the edge of the face it hits lies in the
    plane of the side face too (g = 0 there, to round-off): the tolerance keeps it off
    the side face. ``pair_seg[n]``: the segment index or -1; ``pair_geo[n]``: xi, eta,
    n (3), g. Returns the number of pairs."""
    out, before = np.empty(5), np.empty(5)
    n_pairs = 0
    for n in range(len(nx)):
        pair_seg[n] = -1
        b = bucket_of(nx[n], lo, inv_size, dims)
        if b < 0:
            continue
        best, best_key, best_reach = np.inf, -1, np.inf
        for k in range(start[b], start[b + 1]):
            s = items[k]
            if not touches[nbody[n], seg_body[s]]:
                continue
            # a face that takes part (a pair, or a nearer face not crossed) has its
            # closest point within sqrt((depth + moves)^2 + tol^2) of the node, and one
            # that beats the best within sqrt(best + tie)
            if beyond_reach(seg_x[s], nx[n],
                            min(seg_depth[s] + nmove[n] + seg_move[s] + tol, best_reach)):
                continue
            g, off = closest_point(seg_x[s], nx[n], out)
            if off > tol or g >= seg_depth[s] or -tol <= g <= tol \
                    or g <= -(seg_depth[s] + nmove[n] + seg_move[s]):
                continue
            dist = g * g + off * off
            if not nearer(dist, seg_key[s], best, best_key, TIE * tol * tol):
                continue
            if g < 0.0:
                g0, _ = closest_point(seg_x0[s], nx0[n], before)
                if g0 <= -seg_depth[s]:
                    continue
            best, best_key = dist, seg_key[s]
            best_reach = np.sqrt(best + TIE * tol * tol)
            pair_seg[n] = s if g < 0.0 else -1      # a nearer face not crossed: none
            for c in range(5):
                pair_geo[n, c] = out[c]
            pair_geo[n, 5] = g
        if pair_seg[n] >= 0:
            n_pairs += 1
    return n_pairs


@njit(cache=True)
def node_impulse(inv_ms, v_s, v_nodes, lent_inv_m, phi, n, g, mu, dt, impulse):
    """The impulse I on the contact point C of one pair (the slave node takes -I) and
    the pair's residual depth. ``inv_ms``: the inverse of the mass the slave lends the
    pair, ``lent_inv_m[J]``: phi_J / (the mass master node J lends it), 0 for a rigid or
    held node; 1/m = inv_ms + sum phi_J lent_inv_m[J] is the pair's inverse mass.
    With the relative velocity u = v_s - v_c (v_c = sum phi_J v_J) approaching,
    u.n < 0, and the trial gap g <= 0, the normal part raises u.n by
    d = min(-u.n, -g/dt): the node lands on the face (g/dt) or, already inside, stops.
    The tangential part sticks, u_t m, capped at mu times the normal part (Coulomb).
    Returns m times the depth left after the landing, max(0, -(g + dt d)) (0 unless
    the node was inside the face at the start of the step): the position impulse that
    would put the node back on the face. A pair that does not approach takes no impulse
    but returns m times its whole depth -g (a node left inside is moved out whether or
    not it approaches); -1 when neither side can move (two rigid or held sides)."""
    inv_m = inv_ms
    for j in range(4):
        inv_m += phi[j] * lent_inv_m[j]
    rel = np.empty(3)
    for d in range(3):
        vc = 0.0
        for j in range(4):
            vc += phi[j] * v_nodes[j, d]
        rel[d] = v_s[d] - vc
    approach = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2]
    impulse[:] = 0.0
    if inv_m <= 0.0:
        return -1.0
    if approach >= 0.0:
        return max(0.0, -g) / inv_m
    lift = min(-approach, -g / dt)
    normal = -lift / inv_m                        # along n; negative: C is pushed in
    tangent_norm = 0.0
    for d in range(3):
        impulse[d] = (rel[d] - approach * n[d]) / inv_m
        tangent_norm += impulse[d] * impulse[d]
    tangent_norm = np.sqrt(tangent_norm)
    cap = mu * abs(normal)
    factor = cap / tangent_norm if tangent_norm > cap else 1.0
    for d in range(3):
        impulse[d] = normal * n[d] + factor * impulse[d]
    return max(0.0, -(g + dt * lift)) / inv_m


@njit(cache=True)
def node_pair_impulses(pair_n, pair_s, pair_geo, lent_inv_ms, v, nbody, seg_v, seg_inv_m,
                       seg_body, friction, dt, impulses, depth):
    """``impulses[k]`` (3): the impulse on C of pair k (slave node ``pair_n[k]``, segment
    ``pair_s[k]``), zero for a separating pair; ``depth[k]``: its residual depth times its
    mass (-1: neither side can move). ``lent_inv_ms`` per slave node Phi / m,
    ``seg_inv_m`` (ns, 4) per segment node Phi_J / m_J: the inverses of the masses they lend a pair per unit
    weight (Phi: the sum of the node's weights over all its pairs, 1 as a slave, phi_J
    as a master node)."""
    phi = np.empty(4)
    for k in range(len(pair_n)):
        i, s = pair_n[k], pair_s[k]
        face_shapes(pair_geo[k, 0], pair_geo[k, 1], phi)
        depth[k] = node_impulse(lent_inv_ms[i], v[i], seg_v[s], seg_inv_m[s], phi,
                                pair_geo[k, 2:5], pair_geo[k, 5],
                                friction[nbody[i], seg_body[s]], dt, impulses[k])
