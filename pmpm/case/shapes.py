"""Analytic shapes of a validated ``geometry`` mapping: bounds, containment, reference point.

Each shape is given in its own unrotated frame; ``fill.py`` applies ``rotate``. All
containment tests are vectorised over an (n, 3) array of points and inclusive up to a
relative tolerance of ``TOL``.
"""
import math

import numpy as np

TOL = 1e-9
AXES = {"x": 0, "y": 1, "z": 2}


def reference_point(geometry):
    """The point a rotated lattice is anchored at and ``rotate`` turns about by default:
    box: min corner; cylinder: base centre; sphere: centre; ogive: base (or tip when only
    the tip is given); mesh, surface, points: ``translate`` (where the file's origin
    lands); prism: its section's first point on the base plane; union, difference: the
    first shape's (turned by that shape's own ``rotate``)."""
    kind = geometry["type"]
    if kind == "prism":
        return Prism(geometry).corner().tolist()
    if kind in CSG:
        first = geometry["of"][0]
        return placed_points(np.asarray([reference_point(first)], float), first)[0].tolist()
    key = {"box": "min", "cylinder": "base", "sphere": "center", "mesh": "translate",
           "surface": "translate", "points": "translate"}.get(kind)
    if key is None:
        key = "base" if "base" in geometry else "tip"
    return [float(v) for v in geometry[key]]


def make_shape(geometry):
    """The analytic shape object for a box, cylinder, sphere, ogive, prism, union or
    difference geometry (its own ``rotate`` is not applied: fill.py turns the filled
    points; the shapes inside a union or difference are turned by theirs)."""
    return SHAPES[geometry["type"]](geometry)


class Placed:
    """A shape of a union or difference, turned by its own ``rotate`` (if any) about its
    origin: a point is inside when, turned back, it is inside the unturned shape."""

    def __init__(self, g):
        self.shape, self.rotate = make_shape(g), g.get("rotate")

    def bounds(self):
        """The box around the turned box of the unturned shape's bounds."""
        lo, hi = (np.asarray(b, float) for b in self.shape.bounds())
        if not self.rotate:
            return lo, hi
        corners = np.array([[(lo, hi)[k >> a & 1][a] for a in range(3)] for k in range(8)])
        corners = _turn(corners, self.rotate, inverse=False)
        return corners.min(axis=0), corners.max(axis=0)

    def contains(self, p):
        return self.shape.contains(_turn(p, self.rotate, inverse=True) if self.rotate
                                   else p)


class Union:
    """The points inside any of the shapes ``of``."""

    def __init__(self, g):
        self.parts = [Placed(member) for member in g["of"]]

    def bounds(self):
        boxes = [part.bounds() for part in self.parts]
        return (np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0))

    def contains(self, p):
        inside = np.zeros(len(p), bool)
        for part in self.parts:
            inside |= part.contains(p)
        return inside


class Difference:
    """The points inside the first shape of ``of`` and inside none of the others (their
    surfaces, within the tolerance, are cut away with them)."""

    def __init__(self, g):
        self.parts = [Placed(member) for member in g["of"]]

    def bounds(self):
        return self.parts[0].bounds()

    def contains(self, p):
        inside = self.parts[0].contains(p)
        for part in self.parts[1:]:
            inside &= ~part.contains(p)
        return inside


def placed_points(points, geometry):
    """``points`` of the geometry's own frame turned by its ``rotate`` (if any)."""
    rotate = geometry.get("rotate")
    return _turn(points, rotate, inverse=False) if rotate else points


def _turn(points, rotate, inverse):
    """Points turned by ``rotate`` = {axis, angle_deg, origin} (or back, ``inverse``)."""
    origin = np.asarray(rotate["origin"], float)
    matrix = rotation_matrix(rotate["axis"], rotate["angle_deg"])
    return origin + (points - origin) @ (matrix if inverse else matrix.T)


class Box:
    def __init__(self, g):
        self.lo, self.hi = np.asarray(g["min"], float), np.asarray(g["max"], float)

    def bounds(self):
        return self.lo, self.hi

    def contains(self, p):
        tol = TOL * np.max(self.hi - self.lo)
        return np.all((p >= self.lo - tol) & (p <= self.hi + tol), axis=1)


class Cylinder:
    """Solid or hollow (``inner_radius`` > 0) circular cylinder along x, y or z."""

    def __init__(self, g):
        self.base = np.asarray(g["base"], float)
        self.axis = np.eye(3)[AXES[g["axis"]]]
        self.radius, self.length = g["radius"], g["length"]
        self.inner = g.get("inner_radius", 0.0)

    def bounds(self):
        return axial_bounds(self.base, self.axis, self.length, self.radius)

    def contains(self, p):
        s, r2 = axial_coordinates(p, self.base, self.axis)
        tol = TOL * max(self.radius, self.length)
        inside = (s >= -tol) & (s <= self.length + tol) & (r2 <= (self.radius + tol) ** 2)
        if self.inner > 0:
            inside &= r2 >= (self.inner - tol) ** 2
        return inside


class Sphere:
    def __init__(self, g):
        self.center, self.radius = np.asarray(g["center"], float), g["radius"]

    def bounds(self):
        return self.center - self.radius, self.center + self.radius

    def contains(self, p):
        r2 = np.sum((p - self.center) ** 2, axis=1)
        return r2 <= (self.radius * (1 + TOL)) ** 2


class Ogive:
    """Cylindrical shank with a tangent-ogive nose.

    Notes
    -----
    With diameter D, caliber-radius-head psi (``crh``), ogive radius rho = psi D and
    R = D/2, the nose is L_n = D sqrt(psi - 1/4) long; at distance t from the start of
    the nose (towards the tip) its radius is y(t) = sqrt(rho^2 - t^2) - (rho - R), so
    y(0) = R and y(L_n) = 0. ``crh`` = 0.5 gives a hemispherical nose.
    """

    def __init__(self, g):
        self.axis = np.asarray(g["direction"], float)
        self.axis /= np.linalg.norm(self.axis)
        self.length, self.radius = g["length"], g["diameter"] / 2
        self.rho = g["crh"] * g["diameter"]
        self.nose = nose_length(g["diameter"], g["crh"])
        tip_given = "base" not in g
        self.base = np.asarray(g["tip"] if tip_given else g["base"], float)
        if tip_given:
            self.base = self.base - self.length * self.axis

    def bounds(self):
        return axial_bounds(self.base, self.axis, self.length, self.radius)

    def contains(self, p):
        s, r2 = axial_coordinates(p, self.base, self.axis)
        t = np.clip(s - (self.length - self.nose), 0.0, None)
        y = np.sqrt(np.clip(self.rho ** 2 - t ** 2, 0.0, None)) - (self.rho - self.radius)
        tol = TOL * self.length
        inside_radius = r2 <= (np.clip(y, 0.0, None) + tol) ** 2
        return (s >= -tol) & (s <= self.length + tol) & inside_radius


class Prism:
    """A polygonal section, the union of convex quadrilateral ``blocks`` of the
    ``section`` points, extruded along x, y or z from the plane ``base`` by ``length``.
    The section's points (a, b) are the coordinates ((axis + 1) % 3, (axis + 2) % 3):
    (x, y) for a prism along z, (z, x) along y, (y, z) along x, as for a cylinder."""

    def __init__(self, g):
        self.axis = AXES[g["axis"]]
        self.columns = [(self.axis + 1) % 3, (self.axis + 2) % 3]
        self.points = np.asarray(g["section"], float)
        self.blocks = np.asarray(g["blocks"], np.int64)
        self.base, self.length = float(g["base"]), float(g["length"])

    def corner(self):
        """The section's first point on the base plane, in 3D."""
        out = np.zeros(3)
        out[self.columns] = self.points[0]
        out[self.axis] = self.base
        return out

    def bounds(self):
        lo, hi = np.zeros(3), np.zeros(3)
        used = self.points[np.unique(self.blocks)]
        lo[self.columns], hi[self.columns] = used.min(axis=0), used.max(axis=0)
        lo[self.axis], hi[self.axis] = self.base, self.base + self.length
        return lo, hi

    def contains(self, p):
        lo, hi = self.bounds()
        tol = TOL * np.max(hi - lo)
        s = p[:, self.axis]
        inside = np.zeros(len(p), bool)
        for block in self.blocks:
            inside |= in_convex_polygon(p[:, self.columns], self.points[block], tol)
        return inside & (s >= self.base - tol) & (s <= self.base + self.length + tol)


def in_convex_polygon(q, corners, tol):
    """Which 2D points ``q`` lie in the convex polygon ``corners`` (counter-clockwise),
    within ``tol`` of its edges."""
    inside = np.ones(len(q), bool)
    for k in range(len(corners)):
        a, b = corners[k], corners[(k + 1) % len(corners)]
        edge = b - a
        cross = edge[0] * (q[:, 1] - a[1]) - edge[1] * (q[:, 0] - a[0])
        inside &= cross >= -tol * np.hypot(*edge)
    return inside


def quad_turns(corners):
    """The cross products of consecutive edges at each corner of a 2D quadrilateral
    (all > 0: convex and counter-clockwise)."""
    edges = np.roll(corners, -1, axis=0) - corners
    nxt = np.roll(edges, -1, axis=0)
    return edges[:, 0] * nxt[:, 1] - edges[:, 1] * nxt[:, 0]


SHAPES = {"box": Box, "cylinder": Cylinder, "sphere": Sphere, "ogive": Ogive,
          "prism": Prism, "union": Union, "difference": Difference}
#: the constructive geometries, made of the analytic shapes
CSG = ("union", "difference")


def nose_length(diameter, crh):
    """Length of a tangent-ogive nose: D sqrt(psi - 1/4)."""
    return diameter * math.sqrt(crh - 0.25)


def axial_coordinates(p, base, axis):
    """Distance s along the unit ``axis`` from ``base`` and squared radial distance."""
    rel = p - base
    s = rel @ axis
    return s, np.clip(np.sum(rel * rel, axis=1) - s * s, 0.0, None)


def axial_bounds(base, axis, length, radius):
    """Bounding box of a circular cylinder of ``radius`` from ``base`` along unit ``axis``."""
    tip = base + length * axis
    half_width = radius * np.sqrt(np.clip(1.0 - axis ** 2, 0.0, None))
    return np.minimum(base, tip) - half_width, np.maximum(base, tip) + half_width


def rotation_matrix(axis, angle_deg):
    """Right-handed rotation by ``angle_deg`` about ``axis`` (Rodrigues' formula)."""
    u = np.asarray(axis, float) / np.linalg.norm(axis)
    a = math.radians(angle_deg)
    cross = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return math.cos(a) * np.eye(3) + math.sin(a) * cross + (1 - math.cos(a)) * np.outer(u, u)
