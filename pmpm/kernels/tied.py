"""The tied interface between a refined window and the coarse grid (seed 000 Secs. 3.1-3.2).

A window node on one of the window's faces (or beyond one, where 27-node shape functions
reach past the window's edge) is a *slave* candidate. It lies on the face,
edge or corner of the coarse cells around it; its *master* nodes are the nodes of that
coarse entity, with the coarse trilinear weights at the slave's position (on a face they
are the bilinear phi_m of Eq. 19; on an edge they are linear, at a coarse node 1). The
weights do not depend on which of the coarse cells sharing the entity is taken as the
master cell, so no cell needs to be chosen. A candidate is *tied* when every master node
with a non-zero weight belongs to a coarse cell holding coarse particles (the search of
Sec. 3.2, on nodes: ``occupied``), so a free window face stays free.

Ties are stored as rows ``masters`` (n, 8) (local coarse node, -1 if none) and
``weights`` (n, 8) beside ``slaves`` (n,) (local window node).

The 27-node shape functions also reach one coarse node layer *inside* a window from the
coarse particles next to its faces. Such a coarse node is an *inner slave* of the window
node at the same place (weight 1; :func:`find_inner_ties`, stored the same way with the
roles of the grids swapped): left alone, it would carry only the few coarse particles
that reach it, like a node at a free surface, and the interface would be a soft joint
(a bar's first mode 0.8 % long with B-splines).
"""
import numpy as np
from numba import njit


@njit(cache=True)
def particle_levels(x, origin, inv_h, win_lo, win_hi, level):
    """level[p] = 1 + k when particle p lies in window k (coarse cells win_lo[k] <= c <
    win_hi[k]), else 0 (the coarse grid)."""
    for p in range(x.shape[0]):
        level[p] = 0
        for k in range(win_lo.shape[0]):
            inside = True
            for d in range(3):
                c = np.floor((x[p, d] - origin[d]) * inv_h)
                if c < win_lo[k, d] or c >= win_hi[k, d]:
                    inside = False
                    break
            if inside:
                level[p] = 1 + k
                break


@njit(cache=True)
def mark_occupied(x, level, origin, inv_h, lo, strides, occupied):
    """occupied[n] = 1 for the 8 coarse nodes of every coarse cell holding a particle of
    the coarse grid (level 0)."""
    for p in range(x.shape[0]):
        if level[p] != 0:
            continue
        base = 0
        for d in range(3):
            base += (np.int64(np.floor((x[p, d] - origin[d]) * inv_h)) - lo[d]) * strides[d]
        for a in range(2):
            for b in range(2):
                for c in range(2):
                    occupied[base + a * strides[0] + b * strides[1] + c * strides[2]] = 1


@njit(cache=True)
def find_ties(block, face_lo, face_hi, ratio, coarse, occupied, ties):
    """Tied slave nodes of a window block: nodes on the window's faces and, where the
    shape functions reach beyond them (``pmpm.kernels.shape``), outside them. ``block``:
    the window's NodeBlock (level node indices); ``face_lo, face_hi``: level node index
    of the window's faces; ``coarse``:
    the coarse NodeBlock. Fills the first rows of ``ties`` (a TieSet's ``slaves``,
    ``masters``, ``weights``) and returns how many."""
    shape, lo, strides = block.shape, block.lo, block.strides
    c_shape, c_lo, c_strides = coarse.shape, coarse.lo, coarse.strides
    slaves, masters, weights = ties.slaves, ties.masters, ties.weights
    count = 0
    g = np.empty(3, np.int64)
    for i in range(shape[0]):
        for j in range(shape[1]):
            for k in range(shape[2]):
                g[0], g[1], g[2] = lo[0] + i, lo[1] + j, lo[2] + k
                on_face = False
                for d in range(3):
                    if g[d] <= face_lo[d] or g[d] >= face_hi[d]:
                        on_face = True
                if not on_face:
                    continue
                if _tie(g, ratio, c_shape, c_lo, c_strides, occupied, masters[count],
                        weights[count]):
                    slaves[count] = i * strides[0] + j * strides[1] + k * strides[2]
                    count += 1
    return count


@njit(cache=True)
def _tie(g, ratio, c_shape, c_lo, c_strides, occupied, masters, weights):
    """Master nodes and weights of the slave at level node ``g`` of a window over the
    coarse block (``c_shape``, ``c_lo``, ``c_strides``); False if not tied."""
    cell = np.empty(3, np.int64)
    frac = np.empty(3)
    for d in range(3):
        cell[d] = g[d] // ratio
        frac[d] = (g[d] - cell[d] * ratio) / ratio
    m = 0
    for a in range(2):
        for b in range(2):
            for c in range(2):
                w = ((frac[0] if a else 1.0 - frac[0]) * (frac[1] if b else 1.0 - frac[1])
                     * (frac[2] if c else 1.0 - frac[2]))
                masters[m], weights[m] = -1, 0.0
                if w > 0.0:
                    li, lj, lk = cell[0] + a - c_lo[0], cell[1] + b - c_lo[1], cell[2] + c - c_lo[2]
                    if (li < 0 or lj < 0 or lk < 0 or li >= c_shape[0] or lj >= c_shape[1]
                            or lk >= c_shape[2]):
                        return False
                    n = li * c_strides[0] + lj * c_strides[1] + lk * c_strides[2]
                    if occupied[n] == 0:
                        return False
                    masters[m], weights[m] = n, w
                m += 1
    return True


@njit(cache=True)
def find_inner_ties(coarse, window, inner_lo, inner_hi, shell_lo, shell_hi, ratio, ties):
    """Inner slaves of a window: the coarse nodes (``coarse`` NodeBlock) from
    ``inner_lo`` to ``inner_hi`` (coarse node indices (3,): the window's nodes, less its
    faces that are interfaces) that lie on the layer ``shell_lo`` or ``shell_hi`` (3,),
    the first layer inside an interface face (-1 where there is none), each tied with
    weight 1 to the window node (``window`` NodeBlock) at the same place where this
    rank's window block holds it. Fills the first rows of ``ties``; returns how many."""
    c_lo, c_strides, c_shape = coarse.lo, coarse.strides, coarse.shape
    w_lo, w_strides, w_shape = window.lo, window.strides, window.shape
    first, last, g = np.empty(3, np.int64), np.empty(3, np.int64), np.empty(3, np.int64)
    for d in range(3):
        first[d] = max(inner_lo[d], c_lo[d])
        last[d] = min(inner_hi[d], c_lo[d] + c_shape[d] - 1)
    count = 0
    for i in range(first[0], last[0] + 1):
        for j in range(first[1], last[1] + 1):
            for k in range(first[2], last[2] + 1):
                g[0], g[1], g[2] = i, j, k
                if _inner_slave(g, shell_lo, shell_hi, ratio, w_lo, w_shape):
                    ties.slaves[count] = ((i - c_lo[0]) * c_strides[0] + (j - c_lo[1])
                                          * c_strides[1] + (k - c_lo[2]) * c_strides[2])
                    ties.masters[count, :] = -1
                    ties.weights[count, :] = 0.0
                    ties.masters[count, 0] = ((i * ratio - w_lo[0]) * w_strides[0]
                                              + (j * ratio - w_lo[1]) * w_strides[1]
                                              + (k * ratio - w_lo[2]) * w_strides[2])
                    ties.weights[count, 0] = 1.0
                    count += 1
    return count


@njit(cache=True, inline="always")
def _inner_slave(g, shell_lo, shell_hi, ratio, w_lo, w_shape):
    """Whether coarse node ``g`` (inside the window) is on the first layer inside one of
    its interface faces and its window node is in the window block."""
    shell = False
    for d in range(3):
        if g[d] == shell_lo[d] or g[d] == shell_hi[d]:
            shell = True
        f = g[d] * ratio - w_lo[d]
        if f < 0 or f >= w_shape[d]:
            return False
    return shell


@njit(cache=True)
def slaves_to_masters(ties, fine, coarse):
    """coarse[m] += phi_m fine[s] for every tie of a TieSet: slave mass, momentum
    (Eqs. 17, 20) or force (Eq. 18) added to the master nodes."""
    slaves, masters, weights, count = ties
    for t in range(count):
        s = slaves[t]
        for k in range(8):
            m = masters[t, k]
            if m >= 0:
                for c in range(fine.shape[1]):
                    coarse[m, c] += weights[t, k] * fine[s, c]


@njit(cache=True)
def slaves_to_masters_in_rows(ties, fine, coarse, slave_rows, master_rows):
    """:func:`slaves_to_masters` for the ties whose slave row is in ``slave_rows`` and
    the masters whose row is in ``master_rows`` ((first, stop) each), in the same order:
    each master's terms by slave row. The tied interface's exact sums split one rank's
    adds into those of the ranks that own the slaves (``pmpm.solver.couplings``)."""
    slaves, masters, weights, count = ties
    for t in range(count):
        s = slaves[t]
        if s < slave_rows[0] or s >= slave_rows[1]:
            continue
        for k in range(8):
            m = masters[t, k]
            if m >= master_rows[0] and m < master_rows[1]:
                for c in range(fine.shape[1]):
                    coarse[m, c] += weights[t, k] * fine[s, c]


@njit(cache=True)
def masters_to_slaves(ties, coarse, fine):
    """fine[s] = sum_m phi_m coarse[m]: slave velocity (Eq. 22) or end-of-step velocity
    and acceleration (Eqs. 23-24) interpolated from the master nodes."""
    slaves, masters, weights, count = ties
    for t in range(count):
        for c in range(fine.shape[1]):
            total = 0.0
            for k in range(8):
                if masters[t, k] >= 0:
                    total += weights[t, k] * coarse[masters[t, k], c]
            fine[slaves[t], c] = total


@njit(cache=True)
def clear_slave_slots(ties, mask):
    """mask[s] = 0 at the tied slaves: they follow their masters, not a contact field."""
    slaves, count = ties.slaves, ties.count
    for t in range(count):
        mask[slaves[t]] = 0


@njit(cache=True)
def mark_slaves(ties, tied):
    """tied[s] = 1 at the slaves of a TieSet."""
    for t in range(ties.count):
        tied[ties.slaves[t]] = 1


@njit(cache=True)
def layer_moments(x, mass, order, layer, sums):
    """sums[layer[p], :3] += m_p x_p and sums[layer[p], 3] += m_p for the particles p of
    ``order``, one after the other: per cell layer, in the order's order (a followed
    window's centroid, the same bits on any rank count: solver.refine)."""
    for i in range(order.shape[0]):
        p = order[i]
        row = layer[p]
        for d in range(3):
            sums[row, d] += mass[p] * x[p, d]
        sums[row, 3] += mass[p]
