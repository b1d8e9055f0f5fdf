"""Hexahedral meshes of FEM bodies: a structured mesh of a box, a cylinder (O-grid; a tube
in polar blocks), a sphere (cubed sphere), an ogive (a swept O-grid closed by a half
cubed ball at its pointed tip) or a prism (its section's blocks), or the hexahedra of a
mesh file meshio reads; then the body's ``rotate``. Node order is VTK's
(pmpm.fem.hexahedron).

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


#: Where the ogive's swept disc ends and its cap begins: the section at which the
#: disc's elements (2 r / n wide) are this share of the element size (:func:`ogive_mesh`;
#: at 1 the cap takes most or all of the nose: 0.8 left the 2.3 mm rod's cap corners at
#: 0.39 of a 2 mm cell's step, and its run 1.5 times the 5.7 mm rod's steps; 1 gives
#: 0.53 and the same steps; docs/validation/ogive_plate_fem.md).
CAP_WIDTH = 1.0
#: Sample points of the nose profile for the graded layers' spacing and the cap's
#: meridian.
PROFILE_SAMPLES = 2001


def ogive_mesh(geometry, element_size):
    """(points, hexes) of a validated ``ogive`` geometry (a shank with a tangent-ogive
    nose, pmpm.case.shapes.Ogive), pointed, its elements kept near ``element_size``
    down to the tip.

    Two parts, in the frame (u, v, s) of the axis (base s = 0):

    * the swept disc (:func:`swept_disc`): the solid cylinder's O-grid disc of n =
      ``across(diameter)`` elements across, scaled to the local radius r(s), over the
      shank in round(shank / size) layers and over the nose in layers graded as r(s)
      (:func:`nose_grading`: as the disc's elements narrow with the radius the layers
      thin too, so the elements keep their shape), down to the section of radius
      r_c (:func:`cap_radius`) where the disc's elements are CAP_WIDTH of the size;
    * the cap (:func:`nose_cap`): the upper half of the cubed ball of n elements across
      (:func:`ball_map` of a box of n x n x n/2 elements, whose base is the same O-grid
      disc), each direction of the unit hemisphere taken to the point of the ogive's
      meridian at the same share of its arc from the rim to the point, distances from
      the base's centre kept as shares: n x n x n/2 elements down to the pointed tip.

    Why: a disc that keeps its n elements across down to a tip makes the tip's elements
    as small as the tip's section over n (the earlier mesh cut the nose flat at 0.2 R:
    its tip elements were 0.2 of the head element, and their stable step the shortest
    of the run; docs/validation/ogive_plate_fem.md, "A nose mesh that keeps its element
    size"). In the cap the n elements across span the whole remaining nose, so none is
    much narrower than the cap's section over n (the shortest nose edge is 0.53-0.61 of
    the size for the seed's rods). The price: the cap has n/2 elements from its base's
    centre to the point, so along the axis its elements are longer than the size (up to
    3.1 times for the 2.3 mm rod, whose whole nose is the cap). Blocks of fewer elements
    joined by transition layers are what a hexahedral mesh would otherwise need.

    Every surface node lies on the ogive once scaled across the axis by
    :func:`facet_scale`, which gives each faceted section the area of its circle, so the
    mesh weighs what the ogive does (10 % light at two elements across without it). Then
    direction (the disc's frame is any right-handed one about it) and base or tip place
    it."""
    from .shapes import Ogive
    shape = Ogive(geometry)
    n, shank_layers, nose_layers = (int(c) for c in ogive_counts(geometry, element_size))
    t_cap, swept = swept_nose(shape, n, element_size)
    stations = ogive_stations(shape, shank_layers, int(swept), t_cap)
    points, hexes = swept_disc(n, stations, lambda s: ogive_radius(shape, s))
    cap_points, cap_hexes = nose_cap(n, shape, stations[-1])
    points, hexes = join_cap(n, points, hexes, cap_points, cap_hexes)
    points[:, :2] *= facet_scale(4 * n)
    return shape.base + points @ axis_frame(shape.axis).T, hexes


def ogive_counts(geometry, element_size):
    """(elements across n, shank layers, nose layers) of :func:`ogive_mesh`, as floats (a
    huge count is refused by the caller, before any array is made). The nose's count
    takes the cap's n x n x n/2 elements as n/2 layers, so that n^2 (shank + nose) is the
    mesh's element count."""
    from .shapes import Ogive
    shape = Ogive(geometry)
    size = np.float64(element_size)
    with np.errstate(over="ignore"):
        n = max(np.rint(2.0 * shape.radius / size), 2.0)
        n += np.fmod(n, 2.0)
        shank = shape.length - shape.nose
        shank_layers = max(np.rint(shank / size), 1.0) if shank > 1e-9 * shape.length else 0.0
        swept = swept_nose(shape, n, size)[1]
    return n, shank_layers, swept + n / 2


def swept_nose(shape, n, element_size):
    """(t_cap, layers): the swept disc's part of the nose, from the nose's start to the
    cap's base t_cap (:func:`cap_start`), in round(G(t_cap) / size) graded layers. Where
    that rounds to none (a nose whose elements are already CAP_WIDTH of the size or
    less near its start: a blunt one, or coarse elements) the cap takes the whole nose,
    t_cap = 0, rather than leave a sliver of a layer."""
    t_cap = cap_start(shape, n, element_size)
    layers = np.rint(nose_grading(shape, t_cap)[1][-1] / element_size) if t_cap > 0 \
        else 0.0
    return (t_cap, layers) if layers >= 1 else (0.0, 0.0)


def cap_radius(shape, n, element_size):
    """The radius of the section where the swept disc ends: its n elements across are
    CAP_WIDTH of ``element_size`` wide there (2 r / n), at most the shank's radius."""
    return float(min(CAP_WIDTH * element_size * n / 2.0, shape.radius))


def cap_start(shape, n, element_size):
    """Distance from the nose's start to the cap's base, the section of radius
    :func:`cap_radius` (the profile inverted: t = sqrt(rho^2 - (r + rho - R)^2))."""
    r = cap_radius(shape, n, element_size)
    return float(np.sqrt(max(shape.rho ** 2 - (r + shape.rho - shape.radius) ** 2, 0.0)))


def nose_grading(shape, end):
    """(t, G): G(t) = integral of R / r(t) from the nose's start to t <= ``end``, short of
    the tip: layers G / size apart are as thick as the local element is wide."""
    t = np.linspace(0.0, end, PROFILE_SAMPLES)
    inverse = shape.radius / nose_profile(shape, t)
    steps = np.diff(t) * (inverse[1:] + inverse[:-1]) / 2
    return t, np.concatenate([[0.0], np.cumsum(steps)])


def nose_profile(shape, t):
    """The nose's radius at distance t from its start (0 past the tip)."""
    y = np.sqrt(np.clip(shape.rho ** 2 - np.asarray(t) ** 2, 0.0, None))
    return np.clip(y - (shape.rho - shape.radius), 0.0, None)


def ogive_radius(shape, s):
    """The ogive's radius at distance s from its base."""
    return nose_profile(shape, np.clip(np.asarray(s) - (shape.length - shape.nose), 0.0, None))


def ogive_stations(shape, shank_layers, nose_layers, t_cap):
    """Axial positions of the swept sections: even over the shank, graded by
    :func:`nose_grading` over the nose, ending at the cap's base, ``t_cap`` into the
    nose."""
    shank = shape.length - shape.nose
    along = np.linspace(0.0, shank, shank_layers + 1)
    if nose_layers < 1:
        return along
    t, grading = nose_grading(shape, t_cap)
    nose = np.interp(np.linspace(0.0, grading[-1], nose_layers + 1), grading, t)
    return np.concatenate([along[:-1], shank + nose]) if shank_layers else shank + nose


def swept_disc(n, stations, radius):
    """(points, hexes) in the frame (u, v, s): the O-grid disc of n x n elements scaled
    to ``radius(s)`` at each of the ``stations`` along s."""
    layers = len(stations) - 1
    square, hexes = box_mesh([-1.0, -1.0, 0.0], [1.0, 1.0, float(layers)], [n, n, layers])
    s = np.asarray(stations)[np.rint(square[:, 2]).astype(np.int64)]
    disc = ball_map(square[:, :2], 1.0) * radius(s)[:, None]
    return np.concatenate([disc, s[:, None]], axis=1), hexes


def nose_cap(n, shape, s_base):
    """(points, hexes) in the frame (u, v, s) of the nose beyond ``s_base``: the upper
    half of the cubed ball (:func:`ball_map` of the box [-1, 1]^2 x [0, 1] cut into
    n x n x n/2) mapped onto the ogive's tip. A node at distance d (0 to 1) from the
    ball's centre in the direction of polar angle theta from the axis and azimuth phi
    goes to d times the ogive's point at azimuth phi whose arc along the meridian,
    from the base's rim towards the point, is the share 1 - theta / (pi/2) of the
    whole, measured from the base's centre. The base (theta = pi/2) is then the O-grid
    disc of the base's radius, node for node the swept disc's last section; the
    surface nodes (d = 1) lie on the ogive and the ball's pole (theta = 0) on its point.
    Along the meridian the cap has n elements (n/2 on a side block, n/2 on the top
    block), spread by arc length from rim to point, so no element shrinks into the
    point. The four elements at the box's upper corners have three faces on the
    surface: their corner Jacobians are the mesh's smallest (0.13 of their mean at 2.3
    mm, 0.037 at 20 elements across), still positive because the nose is convex."""
    box, hexes = box_mesh([-1.0, -1.0, 0.0], [1.0, 1.0, 1.0], [n, n, n // 2])
    ball = ball_map(box, 1.0)
    d = np.linalg.norm(ball, axis=1)
    theta = np.arccos(np.clip(np.divide(ball[:, 2], d, out=np.ones_like(d), where=d > 0),
                              -1.0, 1.0))
    phi = np.arctan2(ball[:, 1], ball[:, 0])
    s_surface, r_surface = meridian_at(shape, s_base, 1.0 - theta / (0.5 * np.pi))
    points = np.stack([d * r_surface * np.cos(phi), d * r_surface * np.sin(phi),
                       s_base + d * (s_surface - s_base)], axis=1)
    return points, hexes


def meridian_at(shape, s_base, share):
    """(s, r) of the points of the ogive's meridian beyond ``s_base`` at the ``share``
    (0 at the base's rim, 1 at the point) of its arc length."""
    start = shape.length - shape.nose
    t = np.linspace(s_base - start, shape.nose, PROFILE_SAMPLES)
    r = nose_profile(shape, t)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(t), np.diff(r)))])
    along = np.interp(np.asarray(share) * arc[-1], arc, t)
    return start + along, nose_profile(shape, along)


def join_cap(n, points, hexes, cap_points, cap_hexes):
    """The swept disc and the cap as one mesh: the cap's base nodes (its box's layer 0)
    are the disc's last section's (layer ``layers``), both numbered x slowest, z
    fastest (:func:`box_mesh`), so they are matched by index, not by place."""
    layers = len(points) // ((n + 1) ** 2) - 1
    cap_layers = n // 2
    ij = np.arange((n + 1) ** 2)
    disc_top = ij * (layers + 1) + layers
    cap_base = ij * (cap_layers + 1)
    renumber = np.full(len(cap_points), -1, np.int64)
    renumber[cap_base] = disc_top
    rest = np.flatnonzero(renumber < 0)
    renumber[rest] = len(points) + np.arange(len(rest))
    return (np.concatenate([points, cap_points[rest]]),
            np.concatenate([hexes, renumber[cap_hexes]]))


def facet_scale(sides):
    """The factor that gives the polygon inscribed in a circle, with ``sides`` equal
    sides, the circle's area: sqrt(pi / (sides/2 sin(2 pi / sides))) (1.054 at 8 sides,
    1.006 at 24)."""
    return float(np.sqrt(np.pi / (sides / 2 * np.sin(2 * np.pi / sides))))


def axis_frame(axis):
    """A right-handed orthonormal frame [e1, e2, axis] as columns: the local (u, v, s)
    of a mesh about the unit ``axis`` are e1 u + e2 v + axis s."""
    axis = np.asarray(axis, float)
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e1 = np.cross(helper, axis)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(axis, e1), axis], axis=1)


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


def corner_jacobians(points, hexes):
    """det(dx/dxi) at each element's eight corners, (m, 8): all positive for an element
    that is not inverted or degenerate anywhere (the centre's can be positive while a
    corner's is not)."""
    xe = points[hexes]                               # (m, 8, 3)
    factors = 1.0 + CORNERS[None, :, :] * CORNERS[:, None, :]      # [corner, node, axis]
    dets = np.empty((len(hexes), 8))
    for c in range(8):
        grad = np.empty((8, 3))
        for a in range(3):
            others = [b for b in range(3) if b != a]
            grad[:, a] = CORNERS[:, a] * factors[c, :, others[0]] * factors[c, :, others[1]] / 8
        dets[:, c] = np.linalg.det(np.einsum("mki,ka->mia", xe, grad))
    return dets


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
    """(points, hexes) of an FEM body's validated ``geometry`` (box, cylinder, sphere,
    ogive or mesh), rotated by its ``rotate``. Raises MeshReadError, MixedMeshError or
    InvertedElementError."""
    kind = geometry["type"]
    if kind == "box":
        counts = box_counts(geometry["min"], geometry["max"], element_size)
        points, hexes = box_mesh(geometry["min"], geometry["max"], counts)
    elif kind == "sphere":
        points, hexes = sphere_mesh(geometry["center"], geometry["radius"], element_size)
    elif kind == "ogive":
        points, hexes = ogive_mesh(geometry, element_size)
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
    """{name: node indices} of the node sets of a mesh file, numbered as
    :func:`read_hexes` numbers its points: meshio ``point_sets`` (Abaqus *NSET, ...) and
    the nodes of the cells of each Gmsh physical group (``.msh``: a group of any dimension,
    named by its physical name; nodes no hexahedron uses are left out)."""
    mesh = _read_mesh(path)
    blocks = [np.asarray(b.data)[:, :8] for b in mesh.cells if b.type.startswith("hexahedron")]
    used = np.unique(np.concatenate(blocks)) if blocks else np.zeros(0, np.int64)
    sets = dict(physical_group_nodes(mesh))
    sets.update({str(name): np.asarray(indices, np.int64).ravel()
                 for name, indices in (mesh.point_sets or {}).items()})
    out = {}
    for name, indices in sets.items():
        kept = indices[np.isin(indices, used)]
        out[name] = np.searchsorted(used, kept)
    return out


#: the dimension of meshio's cell types, by the start of their names
CELL_DIMENSIONS = (("vertex", 0), ("line", 1), ("triangle", 2), ("quad", 2),
                   ("polygon", 2), ("tetra", 3), ("hexahedron", 3), ("wedge", 3),
                   ("pyramid", 3))


def cell_dimension(cell_type):
    """0 to 3 for a meshio cell type, None for one not known."""
    for start, dim in CELL_DIMENSIONS:
        if cell_type.startswith(start):
            return dim
    return None


def physical_group_nodes(mesh):
    """{physical name: the mesh's point indices} of the nodes of the cells of each Gmsh
    physical group (meshio's ``field_data`` name -> [tag, dimension]). The cells are
    meshio's ``cell_sets`` of the name where it has them (Gmsh 4.1) or else those whose
    ``gmsh:physical`` tag and dimension are the group's (Gmsh 2.2)."""
    tags = mesh.cell_data.get("gmsh:physical")
    groups = {}
    for name, value in (mesh.field_data or {}).items():
        value = np.asarray(value).ravel()
        if len(value) < 2:
            continue
        chosen = mesh.cell_sets.get(name) if mesh.cell_sets else None
        nodes = []
        for k, block in enumerate(mesh.cells):
            if chosen is not None:
                rows = chosen[k] if k < len(chosen) and chosen[k] is not None else []
            elif tags is not None and cell_dimension(block.type) in (int(value[1]), None):
                rows = np.flatnonzero(np.asarray(tags[k]) == int(value[0]))
            else:
                rows = []
            data = np.asarray(block.data)
            nodes.append(data[np.asarray(rows, np.int64)].ravel() if len(rows) else [])
        groups[str(name)] = np.unique(np.concatenate(nodes + [[]]).astype(np.int64))
    return groups
