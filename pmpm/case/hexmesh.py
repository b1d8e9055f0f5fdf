"""Hexahedral meshes of FEM bodies: a structured mesh of a box, a cylinder (O-grid; a tube
in polar blocks), a sphere (cubed sphere) or a prism (its section's blocks), or the hexahedra of a mesh file meshio
reads; then the body's ``rotate``. Node order is VTK's (pmpm.fem.hexahedron).

Plain numpy: an element is refused when its Jacobian at the centre is not positive
(inverted, or collapsed to no volume), so that the solver never starts on one.
"""
import os

import numpy as np

from .mesh import MeshReadError, _read_mesh
from .shapes import rotation_matrix

#: natural coordinates of the VTK-ordered corners
CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], np.float64)


class InvertedElementError(ValueError):
    """An element whose Jacobian at its centre is not positive."""


class MixedMeshError(ValueError):
    """A mesh file with volume cells other than hexahedra besides its hexahedra."""


class MeshDefectError(ValueError):
    """A mesh file whose hexahedra name nodes it does not have, whose nodes are not
    finite, or that repeats a hexahedron or leaves coincident nodes unmerged."""


#: volume cells an FEM body cannot take (surface and line cells are ignored)
OTHER_VOLUMES = ("tetra", "wedge", "pyramid", "polyhedron")


def box_counts(lo, hi, element_size):
    """Elements per direction of a box: round(edge / element_size), at least 1."""
    edges = np.asarray(hi, float) - np.asarray(lo, float)
    with np.errstate(over="ignore"):                  # a huge count is refused by the caller
        counts = np.minimum(edges / element_size, 2.0 ** 62)
    return np.maximum(np.rint(counts), 1).astype(np.int64)


def box_mesh(lo, hi, counts):
    """(points (n, 3), hexes (m, 8) int64) of a box cut into ``counts`` elements per
    direction; nodes numbered x slowest, z fastest."""
    nx, ny, nz = (int(c) for c in counts)
    axes = [np.linspace(lo[a], hi[a], int(counts[a]) + 1) for a in range(3)]
    grid = np.meshgrid(*axes, indexing="ij")
    points = np.stack([g.ravel() for g in grid], axis=1)
    node = np.arange(len(points)).reshape(nx + 1, ny + 1, nz + 1)
    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz),
                                              indexing="ij"))
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0),
               (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    hexes = np.stack([node[i + a, j + b, k + c] for a, b, c in corners], axis=1)
    return points, hexes.astype(np.int64)


def ball_map(points, radius):
    """Map a box mesh of the cube [-1, 1]^k (k = 2 or 3 columns) onto the ball of
    ``radius``: x = radius ((1 - w) p + w rho p / |p|), rho = |p|_inf, w = sqrt(rho).
    Every node keeps its direction and its distance grows with rho along it (by
    radius (|q| - 1.5 w (|q| - 1)) per unit rho, |q| = |p| / rho <= sqrt(3): at least
    0.63 radius), so the map is one to one; the core stays near a cube and the shells
    round off into the sphere (the cubed-sphere or, in 2D, O-grid blocks, with no
    singular axis). w = rho would squeeze the shell's corner elements to 0.27."""
    rho = np.abs(points).max(axis=1, keepdims=True)
    shell = np.divide(points, rho, out=np.zeros_like(points), where=rho > 0)
    angles = np.tan(0.25 * np.pi * shell)          # equiangular along each shell face
    length = np.linalg.norm(angles, axis=1, keepdims=True)
    unit = np.divide(angles, length, out=np.zeros_like(points), where=length > 0)
    w = np.sqrt(rho)
    return radius * ((1.0 - w) * points + w * rho * unit)


def across(diameter, element_size):
    """Elements across a diameter: round(diameter / size), even (a node on the axis), >= 2."""
    n = max(int(np.rint(diameter / element_size)), 2)
    return n + n % 2


def sphere_mesh(center, radius, element_size):
    """(points, hexes) of a cubed-sphere mesh: ``across`` elements along each axis."""
    n = across(2.0 * radius, element_size)
    points, hexes = box_mesh([-1.0] * 3, [1.0] * 3, [n, n, n])
    return np.asarray(center, float) + ball_map(points, radius), hexes


def cylinder_mesh(base, axis, radius, length, inner_radius, element_size):
    """(points, hexes) of a cylinder along ``axis`` ("x", "y" or "z") from ``base``: a
    solid one as an O-grid disc (:func:`ball_map` of a square) swept along the axis, a
    tube (inner_radius > 0) as polar blocks, both round(length / size) layers long."""
    layers = int(max(np.rint(length / element_size), 1))
    if inner_radius > 0:
        n_r = int(max(np.rint((radius - inner_radius) / element_size), 1))
        n_t = int(max(np.rint(np.pi * (radius + inner_radius) / element_size), 8))
        polar, hexes = box_mesh([inner_radius, 0.0, 0.0], [radius, 1.0, length],
                                [n_r, n_t, layers])
        angle = 2.0 * np.pi * polar[:, 1]
        local = np.stack([polar[:, 0] * np.cos(angle), polar[:, 0] * np.sin(angle),
                          polar[:, 2]], axis=1)
        local, hexes = merge_coincident(local, hexes)
    else:
        n = across(2.0 * radius, element_size)
        square, hexes = box_mesh([-1.0, -1.0, 0.0], [1.0, 1.0, length], [n, n, layers])
        local = np.concatenate([ball_map(square[:, :2], radius), square[:, 2:]], axis=1)
    a = "xyz".index(axis)
    order = [(a + 1) % 3, (a + 2) % 3, a]          # local (u, v, w) -> global columns
    points = np.empty_like(local)
    points[:, order] = local
    return np.asarray(base, float) + points, hexes


def prism_divisions(section, blocks, element_size):
    """Elements along each block edge of a prism's section: round(mean block edge /
    element_size), at least 1 (one count for all, so neighbours' edges match)."""
    corners = np.asarray(section, float)[np.asarray(blocks)]
    edges = np.linalg.norm(np.roll(corners, -1, axis=1) - corners, axis=2)
    return int(max(np.rint(edges.mean() / element_size), 1))


def prism_mesh(geometry, element_size):
    """(points, hexes) of a prism: each convex block of the section cut into n x n
    bilinear elements (:func:`prism_divisions`), swept along the axis in
    round(length / size) layers; nodes that blocks share are merged."""
    n = prism_divisions(geometry["section"], geometry["blocks"], element_size)
    layers = int(max(np.rint(geometry["length"] / element_size), 1))
    section = np.asarray(geometry["section"], float)
    parts, hexes, offset = [], [], 0
    for block in geometry["blocks"]:
        unit, cells = box_mesh([0.0, 0.0, 0.0], [1.0, 1.0, geometry["length"]],
                               [n, n, layers])
        s, t = unit[:, :1], unit[:, 1:2]
        c = section[list(block)]
        ab = ((1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2]
              + (1 - s) * t * c[3])
        parts.append(np.concatenate([ab, unit[:, 2:]], axis=1))
        hexes.append(cells + offset)
        offset += len(unit)
    local, hexes = merge_coincident(np.concatenate(parts), np.concatenate(hexes))
    a = "xyz".index(geometry["axis"])
    points = np.empty_like(local)
    points[:, [(a + 1) % 3, (a + 2) % 3, a]] = local
    points[:, a] += geometry["base"]
    return points, hexes


def merge_coincident(points, hexes):
    """Merge nodes at the same place (a polar mesh's seam), renumbering ``hexes``."""
    keys = np.round(points / (np.abs(points).max() + 1.0), 12)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    return points[first], inverse.reshape(-1)[hexes]


def read_hexes(path, scale=1.0, translate=(0.0, 0.0, 0.0)):
    """(points, hexes) of the hexahedra of a mesh file (first 8 nodes of hexahedron20/27
    cells), scaled then translated, unused points dropped. MeshReadError when the file
    cannot be read or holds no hexahedron."""
    mesh = _read_mesh(path)
    points = np.asarray(mesh.points, float)
    if points.ndim != 2 or points.shape[1] != 3:
        raise MeshReadError(f"points are not 3D (shape {points.shape})")
    blocks = [np.asarray(b.data) for b in mesh.cells if b.type.startswith("hexahedron")]
    blocks = [b.reshape(len(b), -1)[:, :8] for b in blocks if len(b)]   # empty blocks left out
    if not blocks:
        found = ", ".join(f"{block.type} ({len(block.data)})" for block in mesh.cells)
        raise MeshReadError(f"no hexahedron cells, which an FEM body needs (found: "
                            f"{found or 'none'})")
    refuse_other_volumes(mesh.cells)
    hexes = np.concatenate(blocks).astype(np.int64)
    check_node_indices(hexes, len(points))
    used, hexes = np.unique(hexes, return_inverse=True)
    check_coordinates(points, used)
    hexes = hexes.reshape(-1, 8)
    check_repeated_hexahedra(hexes)
    check_merged_nodes(points[used], used)
    return points[used] * scale + np.asarray(translate, float), hexes


def check_node_indices(hexes, n_points):
    """MeshDefectError naming the first hexahedron that names a node the mesh does not
    have (a negative index would silently wrap to the last nodes)."""
    bad = np.flatnonzero(((hexes < 0) | (hexes >= n_points)).any(axis=1))
    if len(bad):
        row = hexes[bad[0]]
        node = int(row[(row < 0) | (row >= n_points)][0])
        raise MeshDefectError(
            f"hexahedron {int(bad[0])} (of {len(bad)} such) names node {node}, but the "
            f"mesh's nodes are 0 to {n_points - 1}")


def check_coordinates(points, used):
    """MeshDefectError naming the first used node whose coordinates are not finite."""
    finite = np.isfinite(points[used]).all(axis=1)
    if not finite.all():
        bad = np.flatnonzero(~finite)
        node = int(used[bad[0]])
        raise MeshDefectError(
            f"node {node} (of {len(bad)} such) has coordinates that are not finite "
            f"({', '.join(f'{v:g}' for v in points[node])})")


def check_repeated_hexahedra(hexes):
    """MeshDefectError when a hexahedron's nodes are another's (its mass would count
    twice: 12.5 % extra mass from one repeat in eight)."""
    keys = np.sort(hexes, axis=1)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    if len(first) == len(hexes):
        return
    repeat = np.flatnonzero(first[inverse.reshape(-1)] != np.arange(len(hexes)))
    original = int(first[inverse.reshape(-1)[repeat[0]]])
    raise MeshDefectError(
        f"{len(hexes) - len(first)} hexahedra repeat another's nodes (hexahedron "
        f"{int(repeat[0])} is hexahedron {original} again): their mass would count twice; "
        f"remove the repeats")


def check_merged_nodes(points, ids):
    """MeshDefectError when distinct nodes lie at the same place (to 1e-9 of the mesh's
    size): elements that touch there share no node, so they are not connected."""
    size = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    keys = np.round(points / max(size, 1e-300) * 1e9)
    _, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    if len(first) == len(points):
        return
    place = np.flatnonzero(counts > 1)[0]
    same = np.flatnonzero((keys == keys[first[place]]).all(axis=1))
    raise MeshDefectError(
        f"{len(points) - len(first)} nodes lie at the same place as another node (nodes "
        f"{int(ids[same[0]])} and {int(ids[same[1]])} at "
        f"({', '.join(f'{v:g}' for v in points[same[0]])})): the elements there share no "
        f"node and are not connected; merge the mesh's coincident nodes")


def refuse_other_volumes(cells):
    """MixedMeshError counting the tetrahedra, wedges, pyramids and polyhedra beside the
    hexahedra (they would be left out of the body, silently changing its shape)."""
    counts = {}
    for block in cells:
        if block.type.startswith(OTHER_VOLUMES):
            counts[block.type] = counts.get(block.type, 0) + len(block.data)
    if counts:
        found = ", ".join(f"{n} {kind}" for kind, n in sorted(counts.items()))
        raise MixedMeshError(f"the mesh holds {found} cells besides its hexahedra; an FEM "
                             f"body takes hexahedra only (give a mesh of hexahedra alone)")


def centre_jacobians(points, hexes):
    """det(dx/dxi) at each element's centre (xi = 0): 1/8 of a parallelepiped's volume."""
    xe = points[hexes]                               # (m, 8, 3)
    jac = np.einsum("mki,ka->mia", xe, CORNERS) / 8.0
    return np.linalg.det(jac)


def check_orientation(points, hexes):
    """InvertedElementError naming the first element (and how many) whose centre
    Jacobian is not positive."""
    det = centre_jacobians(points, hexes)
    bad = np.flatnonzero(~(det > 0))
    if len(bad):
        raise InvertedElementError(
            f"element {int(bad[0])} (of {len(bad)} such) is inverted or has no volume "
            f"(Jacobian {det[bad[0]]:.3g} at its centre); number its nodes in VTK order, "
            f"0-3 counter-clockwise seen from 4-7")


def hex_mesh(geometry, element_size, case_dir="."):
    """(points, hexes) of an FEM body's validated ``geometry`` (box, cylinder, sphere or
    mesh), rotated by its ``rotate``. Raises MeshReadError, MixedMeshError or
    InvertedElementError."""
    kind = geometry["type"]
    if kind == "box":
        counts = box_counts(geometry["min"], geometry["max"], element_size)
        points, hexes = box_mesh(geometry["min"], geometry["max"], counts)
    elif kind == "sphere":
        points, hexes = sphere_mesh(geometry["center"], geometry["radius"], element_size)
    elif kind == "cylinder":
        points, hexes = cylinder_mesh(geometry["base"], geometry["axis"], geometry["radius"],
                                      geometry["length"], geometry["inner_radius"],
                                      element_size)
    elif kind == "prism":
        points, hexes = prism_mesh(geometry, element_size)
    else:
        points, hexes = read_hexes(os.path.join(case_dir, geometry["file"]),
                                   geometry["scale"], geometry["translate"])
    rotate = geometry.get("rotate")
    if rotate:
        origin = np.asarray(rotate["origin"], float)
        matrix = rotation_matrix(rotate["axis"], rotate["angle_deg"])
        points = origin + (points - origin) @ matrix.T
    check_orientation(points, hexes)
    return points, hexes


def read_node_sets(path):
    """{name: node indices} of the node sets (meshio ``point_sets``: Abaqus *NSET, ...) of
    a mesh file, numbered as :func:`read_hexes` numbers its points."""
    mesh = _read_mesh(path)
    blocks = [np.asarray(b.data)[:, :8] for b in mesh.cells if b.type.startswith("hexahedron")]
    used = np.unique(np.concatenate(blocks)) if blocks else np.zeros(0, np.int64)
    sets = {}
    for name, indices in (mesh.point_sets or {}).items():
        indices = np.asarray(indices, np.int64).ravel()
        kept = indices[np.isin(indices, used)]
        sets[str(name)] = np.searchsorted(used, kept)
    return sets
