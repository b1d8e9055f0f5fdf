"""Closed triangulated surfaces (STL, OBJ, or any surface meshio reads) filled with
lattice points (``geometry: {type: surface}``).

The surface is read with meshio; quads and polygons are cut into triangles, vertices at
the same place merged. It must be closed: every edge is shared by exactly two triangles
(an open surface has no inside, and is refused naming an edge of its hole), and the
triangles must be oriented consistently (each edge run once each way), as a solid's
surface from a CAD exporter is. A lattice point is inside when a majority of the three
rays along x, y and z through it cross the surface an odd number of times below it
(pmpm.kernels.inside: exact tie rule on edges and vertices, so the vote only matters for
points within round-off of the surface).
"""
import numpy as np

from .mesh import CHUNK, MeshReadError, _read_mesh
from .shapes import TOL

SURFACE_CELLS = ("triangle", "quad", "polygon")


class SurfaceError(Exception):
    """A surface that is not closed or not consistently oriented, or encloses nothing."""


def read_surface(path, scale=1.0, translate=(0.0, 0.0, 0.0)):
    """(points (n, 3), triangles (m, 3) int64) of the closed surface in ``path``, scaled
    then translated. MeshReadError when it cannot be read or holds no surface cell;
    SurfaceError when it is not closed, not consistently oriented or encloses no
    volume."""
    mesh = _read_mesh(path)
    points = np.asarray(mesh.points, float)
    if points.ndim != 2 or points.shape[1] != 3:
        raise MeshReadError(f"points are not 3D (shape {points.shape})")
    triangles = _triangles(mesh.cells)
    if len(triangles) == 0:
        found = ", ".join(sorted({block.type for block in mesh.cells})) or "none"
        raise MeshReadError(f"no triangle, quad or polygon cells (found: {found})")
    points, triangles = _merged(points, triangles)
    check_closed(points, triangles)
    points = points * scale + np.asarray(translate, float)
    if not surface_volume(points, triangles) > 0:
        raise SurfaceError("the surface encloses no volume")
    return points, triangles


def _triangles(cells):
    """Every surface cell as triangles (a fan from its first vertex)."""
    out = []
    for block in cells:
        data = np.asarray(block.data)
        if block.type not in SURFACE_CELLS or len(data) == 0:
            continue
        for k in range(1, data.shape[1] - 1):
            out.append(data[:, [0, k, k + 1]])
    return np.concatenate(out).astype(np.int64) if out else np.zeros((0, 3), np.int64)


def _merged(points, triangles):
    """Vertices at the same coordinates merged (an STL file repeats them per facet),
    unused ones dropped, triangles with a repeated vertex left out."""
    unique, inverse = np.unique(points, axis=0, return_inverse=True)
    triangles = inverse.reshape(-1)[triangles]
    keep = (triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2]) & \
        (triangles[:, 2] != triangles[:, 0])
    return unique, triangles[keep]


def check_closed(points, triangles):
    """SurfaceError unless every edge belongs to exactly two triangles that run it in
    opposite directions."""
    directed = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]],
                               triangles[:, [2, 0]]])
    undirected = np.sort(directed, axis=1)
    edges, counts = np.unique(undirected, axis=0, return_counts=True)
    if (counts != 2).any():
        bad = edges[counts != 2]
        lone = int(np.count_nonzero(counts == 1))
        u, v = (", ".join(f"{c:g}" for c in points[i]) for i in bad[0])
        raise SurfaceError(
            f"not a closed surface: {lone} edges belong to one triangle only and "
            f"{len(bad) - lone} to more than two (e.g. the edge from ({u}) to ({v})); "
            f"only a closed (watertight) surface has an inside: close its holes")
    _, runs = np.unique(directed, axis=0, return_counts=True)
    if (runs != 1).any():
        raise SurfaceError(
            f"the triangles are not oriented consistently ({int(np.sum(runs > 1))} edges "
            f"are run the same way by both their triangles): orient the facets' normals "
            f"all outwards")


def surface_volume(points, triangles):
    """The volume the closed surface encloses (divergence theorem; either orientation)."""
    p = points[triangles]
    return float(abs(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum()) / 6)


def lattice_points_in_surface(points, triangles, anchor, spacing, clip=None):
    """Lattice points anchor + (i + 1/2) spacing inside the closed surface (and inside the
    box ``clip`` = (lo, hi), if given), in lattice order (x slowest, z fastest)."""
    anchor = np.asarray(anchor, float)
    lo, hi = points.min(axis=0), points.max(axis=0)
    if clip is not None:
        lo, hi = np.maximum(lo, clip[0]), np.minimum(hi, clip[1])
        if np.any(lo > hi):
            return np.zeros((0, 3))
    first = np.ceil((lo - anchor) / spacing - 0.5 - TOL).astype(np.int64)
    counts = np.floor((hi - anchor) / spacing - 0.5 + TOL).astype(np.int64) - first + 1
    if np.any(counts <= 0):
        return np.zeros((0, 3))
    from ..kernels.inside import parity_inside     # numba: not for a case's validation
    rays = [_crossings(points, triangles, axis, anchor, spacing, first, counts)
            for axis in range(3)]
    kept = []
    for index in _index_slabs(first, counts):
        votes = sum(parity_inside(index, axis, first, counts, starts, ts, anchor, spacing)
                    .astype(np.int8) for axis, (starts, ts) in enumerate(rays))
        kept.append(index[votes >= 2])
    index = np.concatenate(kept + [np.zeros((0, 3), np.int64)])
    return anchor + (index + 0.5) * spacing


def _crossings(points, triangles, axis, anchor, spacing, first, counts):
    """(starts, ts): the crossings along ``axis`` of every column, sorted, column c's
    being ts[starts[c]:starts[c + 1]]."""
    from ..kernels.inside import column_crossings
    cols, ts = column_crossings(points, triangles, axis, anchor, spacing, first, counts)
    a, b = (axis + 1) % 3, (axis + 2) % 3
    order = np.lexsort((ts, cols))
    cols, ts = cols[order], ts[order]
    starts = np.searchsorted(cols, np.arange(counts[a] * counts[b] + 1))
    return starts.astype(np.int64), ts


def _index_slabs(first, counts, max_points=CHUNK):
    """The integer lattice indices of the box, (n, 3) arrays of whole x planes of at
    most about ``max_points`` each."""
    per_plane = max(int(counts[1] * counts[2]), 1)
    step = max(max_points // per_plane, 1)
    axes = [first[a] + np.arange(counts[a]) for a in range(3)]
    for start in range(0, counts[0], step):
        mesh = np.meshgrid(axes[0][start:start + step], axes[1], axes[2], indexing="ij")
        yield np.stack([m.ravel() for m in mesh], axis=1)
