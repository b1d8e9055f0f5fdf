"""Volume meshes (any format meshio reads) as sets of tetrahedra, and lattice points in them.

Tetra cells (``tetra``, ``tetra10``: first four nodes) are used as they are; hexahedra
(``hexahedron``, ``hexahedron20``, ``hexahedron27``: first eight nodes, VTK order) are
split into six tetrahedra around the 0-6 diagonal. Other cells (surface triangles, lines)
are ignored.
"""
import contextlib
import io
import os

import numpy as np

# six tetrahedra sharing the diagonal 0-6 of a VTK-ordered hexahedron
HEX_TO_TETS = np.array([[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6],
                        [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]])
CHUNK = 1_000_000          # candidate points tested at once (bounds memory)
TOL = 1e-10                # barycentric tolerance: points on shared faces are kept once


class MeshReadError(Exception):
    """A mesh file that is missing, unreadable or holds no volume cells."""


def read_tets(path, scale=1.0, translate=(0.0, 0.0, 0.0)):
    """(m, 4, 3) float64 vertices of the mesh's tetrahedra, scaled then translated."""
    mesh = _read_mesh(path)
    points = np.asarray(mesh.points, float)
    if points.ndim != 2 or points.shape[1] != 3:
        raise MeshReadError(f"points are not 3D (shape {points.shape})")
    tets = _tet_connectivity(mesh.cells)
    if len(tets) == 0:
        found = ", ".join(sorted({block.type for block in mesh.cells})) or "none"
        raise MeshReadError(f"no tetra or hexahedron cells (found: {found})")
    return points[tets] * scale + np.asarray(translate, float)


def _read_mesh(path):
    """meshio.read, quietly: meshio prints to stdout/stderr and may call sys.exit."""
    import meshio
    if not os.path.isfile(path):
        raise MeshReadError("no such file")
    said = io.StringIO()
    try:
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            return meshio.read(path)
    except (Exception, SystemExit) as error:         # meshio raises many kinds
        text = said.getvalue() if isinstance(error, SystemExit) else str(error)
        reason = " ".join(text.split()).removeprefix("Error: ")
        raise MeshReadError(reason or type(error).__name__) from None


def _tet_connectivity(cells):
    blocks = []
    for block in cells:
        data = np.asarray(block.data)
        if len(data) == 0:                   # an empty block (some readers give shape (0,))
            continue
        if block.type.startswith("tetra"):
            blocks.append(data[:, :4])
        elif block.type.startswith("hexahedron"):
            blocks.append(data[:, :8][:, HEX_TO_TETS].reshape(-1, 4))
    return np.concatenate(blocks) if blocks else np.zeros((0, 4), int)


def lattice_points_in_tets(tets, anchor, spacing):
    """Points anchor + (i + 1/2) * spacing (i integer triples) inside any tetrahedron.

    Notes
    -----
    For each tetrahedron, the lattice points inside its bounding box are candidates;
    candidates of all tetrahedra are generated at once by repeat/offset arithmetic and
    tested with barycentric coordinates. A point inside several tetrahedra (on a shared
    face) is kept once. The result is ordered by lattice index.
    """
    tets = tets[_nondegenerate(tets)]
    if len(tets) == 0:
        return np.zeros((0, 3))
    anchor = np.asarray(anchor, float)
    first = np.ceil((tets.min(axis=1) - anchor) / spacing - 0.5 - TOL).astype(np.int64)
    last = np.floor((tets.max(axis=1) - anchor) / spacing - 0.5 + TOL).astype(np.int64)
    counts = np.clip(last - first + 1, 0, None)
    keys = [_inside_keys(tets[c], first[c], counts[c], anchor, spacing)
            for c in _chunks(counts.prod(axis=1))]
    index = _decode(np.unique(np.concatenate(keys + [np.zeros(0, np.int64)])))
    return anchor + (index + 0.5) * spacing


def _nondegenerate(tets):
    edges = tets[:, 1:] - tets[:, :1]
    volume = np.abs(np.linalg.det(edges))
    return volume > 1e-12 * np.max(volume, initial=0.0)


def _chunks(sizes):
    """Index arrays of consecutive tetrahedra with about CHUNK candidates each."""
    group = (np.cumsum(sizes) - sizes) // CHUNK
    return np.split(np.arange(len(sizes)), np.flatnonzero(np.diff(group)) + 1)


def _inside_keys(tets, first, counts, anchor, spacing):
    per_tet = counts.prod(axis=1)
    owner = np.repeat(np.arange(len(tets)), per_tet)
    k = np.arange(per_tet.sum()) - np.repeat(np.cumsum(per_tet) - per_tet, per_tet)
    ny, nz = counts[owner, 1], counts[owner, 2]
    index = first[owner] + np.stack([k // (ny * nz), (k // nz) % ny, k % nz], axis=1)
    points = anchor + (index + 0.5) * spacing
    inverse = np.linalg.inv(np.transpose(tets[:, 1:] - tets[:, :1], (0, 2, 1)))
    lam = np.einsum("nij,nj->ni", inverse[owner], points - tets[owner, 0])
    inside = np.all(lam >= -TOL, axis=1) & (lam.sum(axis=1) <= 1 + TOL)
    return _encode(index[inside])


_OFFSET = 1 << 20          # lattice indices must lie in [-2^20, 2^20)


def _encode(index):
    shifted = index + _OFFSET
    return (shifted[:, 0] << 42) | (shifted[:, 1] << 21) | shifted[:, 2]


def _decode(keys):
    mask = (1 << 21) - 1
    return np.stack([(keys >> 42) & mask, (keys >> 21) & mask, keys & mask], axis=1) - _OFFSET
