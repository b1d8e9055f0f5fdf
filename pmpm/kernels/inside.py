"""Which lattice points lie inside a closed triangulated surface: ray parity along lattice
columns, set-up kernels (no MPI, no configuration).

For a ray along axis ``k`` through a column of lattice points, the surface's crossings
are where the column's point (a, b) in the other two axes falls inside a triangle's
projection. A column through an edge or a vertex of the projection is decided by a tie
rule that is the same in every triangle sharing that edge: each edge's 2D edge function
is evaluated with its end points in a fixed order (lower vertex index first), so that it
is bitwise the same number in both triangles, and a point on an edge belongs to the
triangle whose (counter-clockwise) edge points "down or right" (the top-left rule of
rasterisers). This is the parity of a ray displaced by an infinitesimal, so a closed
surface is crossed an even number of times by every column, and a point is inside when
the crossings below it along the column are odd in number.
"""
import numpy as np
from numba import njit


@njit(cache=True)
def _edge(points, u, v, a, b, pa, pb):
    """(edge function of the point (pa, pb) for the edge u-v, sign of the direction): the
    function is evaluated from the lower-index end so that it is the same in both
    triangles that share the edge; the sign is +1 when u < v."""
    if u > v:
        u, v, s = v, u, -1.0
    else:
        s = 1.0
    ea, eb = points[v, a] - points[u, a], points[v, b] - points[u, b]
    return s * (ea * (pb - points[u, b]) - eb * (pa - points[u, a]))


@njit(cache=True)
def _covers(points, tri, a, b, pa, pb, orient):
    """Whether the point (pa, pb) lies in the projection of triangle ``tri`` of
    orientation ``orient`` (+1 or -1), edges decided by the top-left rule."""
    for e in range(3):
        u, v = tri[e], tri[(e + 1) % 3]
        f = orient * _edge(points, u, v, a, b, pa, pb)
        if f < 0.0:
            return False
        if f == 0.0:
            da = orient * (points[v, a] - points[u, a])
            db = orient * (points[v, b] - points[u, b])
            if not (db < 0.0 or (db == 0.0 and da > 0.0)):
                return False
    return True


@njit(cache=True)
def column_crossings(points, triangles, axis, anchor, spacing, first, counts):
    """Crossings of the surface with the lattice columns along ``axis``: (column ids,
    coordinates along the axis), counted in a first sweep over the triangles and stored
    in a second. The columns are the lattice points anchor + (i + 1/2) spacing with
    index i[a] in first[a] .. first[a] + counts[a] - 1 for the other two axes (a, b),
    numbered (i[a] - first[a]) * counts[b] + (i[b] - first[b])."""
    a, b = (axis + 1) % 3, (axis + 2) % 3
    total = 0
    cols = np.empty(0, np.int64)
    ts = np.empty(0, np.float64)
    for sweep in range(2):
        if sweep == 1:
            cols = np.empty(total, np.int64)
            ts = np.empty(total, np.float64)
        n_out = 0
        for t in range(triangles.shape[0]):
            tri = triangles[t]
            p0, p1, p2 = points[tri[0]], points[tri[1]], points[tri[2]]
            area = (p1[a] - p0[a]) * (p2[b] - p0[b]) - (p1[b] - p0[b]) * (p2[a] - p0[a])
            if area == 0.0:
                continue                   # edge-on: a displaced ray misses it
            orient = 1.0 if area > 0.0 else -1.0
            lo_a = min(p0[a], p1[a], p2[a])
            hi_a = max(p0[a], p1[a], p2[a])
            lo_b = min(p0[b], p1[b], p2[b])
            hi_b = max(p0[b], p1[b], p2[b])
            # one column more each side: _covers decides a column on the box's edge
            ia0 = max(int(np.ceil((lo_a - anchor[a]) / spacing - 0.5)) - 1, first[a])
            ia1 = min(int(np.floor((hi_a - anchor[a]) / spacing - 0.5)) + 1,
                      first[a] + counts[a] - 1)
            ib0 = max(int(np.ceil((lo_b - anchor[b]) / spacing - 0.5)) - 1, first[b])
            ib1 = min(int(np.floor((hi_b - anchor[b]) / spacing - 0.5)) + 1,
                      first[b] + counts[b] - 1)
            normal = ((p1[b] - p0[b]) * (p2[axis] - p0[axis])
                      - (p1[axis] - p0[axis]) * (p2[b] - p0[b]),
                      (p1[axis] - p0[axis]) * (p2[a] - p0[a])
                      - (p1[a] - p0[a]) * (p2[axis] - p0[axis]))
            for ia in range(ia0, ia1 + 1):
                pa = anchor[a] + (ia + 0.5) * spacing
                for ib in range(ib0, ib1 + 1):
                    pb = anchor[b] + (ib + 0.5) * spacing
                    if not _covers(points, tri, a, b, pa, pb, orient):
                        continue
                    if sweep == 1:
                        # the plane through p0: n . (p - p0) = 0 solved for p[axis]
                        cols[n_out] = (ia - first[a]) * counts[b] + (ib - first[b])
                        ts[n_out] = p0[axis] - (normal[0] * (pa - p0[a])
                                                + normal[1] * (pb - p0[b])) / area
                    n_out += 1
        total = n_out
    return cols, ts


@njit(cache=True)
def parity_inside(index, axis, first, counts, starts, ts, anchor, spacing):
    """For lattice points of integer ``index`` (n, 3): whether an odd number of the
    column's crossings ``ts[starts[c]:starts[c + 1]]`` lie below the point along
    ``axis``."""
    a, b = (axis + 1) % 3, (axis + 2) % 3
    out = np.zeros(index.shape[0], np.bool_)
    for p in range(index.shape[0]):
        ja, jb = index[p, a] - first[a], index[p, b] - first[b]
        if ja < 0 or jb < 0 or ja >= counts[a] or jb >= counts[b]:
            continue
        c = ja * counts[b] + jb
        s = anchor[axis] + (index[p, axis] + 0.5) * spacing
        below = 0
        for k in range(starts[c], starts[c + 1]):
            if ts[k] < s:
                below += 1
        out[p] = below % 2 == 1
    return out
