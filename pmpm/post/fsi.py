"""Reading a fluid-structure run back (serial): the FE nodes' paths from ``elements.h5``
and the particles found inside the deformed elements (seed 004 Sec. 4.3, runs/
water_column.yaml). Plane strain: the elements are one layer thick along z, so each is
a quadrilateral in the x-y plane. The falling wedge's momentum balances (von Karman's
added mass, Wagner's pile-up; seed 004 Sec. 4.4, runs/wedge_entry.yaml) to compare its
velocity with."""
import os

import h5py
import numpy as np

from .frames import read_frame


def node_paths(out_dir):
    """(times (nf,), node positions (nf, nn, 3), hexes (ne, 8)) of every element frame."""
    with h5py.File(os.path.join(out_dir, "elements.h5"), "r") as f:
        names = sorted(f["frames"], key=int)
        times = np.array([float(f["frames"][n].attrs["time"]) for n in names])
        x = np.stack([f["frames"][n]["node_x"][()] for n in names])
        hexes = f["mesh"]["hexes"][()]
    return times, x, hexes


def corner_nodes(x0, corner):
    """The nodes at the extreme corner of the mesh at t = 0 in the x-y plane, e.g.
    corner = (-1, +1) for the upper-left edge (its nodes along z)."""
    score = corner[0] * x0[:, 0] + corner[1] * x0[:, 1]
    return np.flatnonzero(score >= score.max() - 1e-9 * (1.0 + abs(score.max())))


def corner_displacement(out_dir, corner=(-1, 1)):
    """(times, mean displacement (nf, 3)) of the nodes at ``corner`` (see corner_nodes)."""
    times, x, _ = node_paths(out_dir)
    nodes = corner_nodes(x[0], corner)
    return times, x[:, nodes].mean(axis=1) - x[0, nodes].mean(axis=0)


def element_quads(x, hexes):
    """(ne, 4, 2) x-y corners of each one-layer hexahedron, counter-clockwise: its four
    distinct in-plane corners (the lower-z node of each pair), sorted by angle about
    their centroid."""
    quads = np.empty((len(hexes), 4, 2))
    for e, hexa in enumerate(hexes):
        pts = x[hexa]
        low = pts[np.argsort(pts[:, 2], kind="stable")[:4], :2]
        centre = low.mean(axis=0)
        angle = np.arctan2(low[:, 1] - centre[1], low[:, 0] - centre[0])
        quads[e] = low[np.argsort(angle, kind="stable")]
    return quads


def inside_quads(points, quads, margin=0.0):
    """(n,) bool: the x-y points deeper than ``margin`` inside any convex quadrilateral."""
    inside = np.zeros(len(points), dtype=bool)
    for quad in quads:
        depth = np.full(len(points), np.inf)
        for k in range(4):
            a, b = quad[k], quad[(k + 1) % 4]
            edge = b - a
            length = np.hypot(edge[0], edge[1])
            # counter-clockwise: the interior lies to the left of each edge
            left = (edge[0] * (points[:, 1] - a[1]) - edge[1] * (points[:, 0] - a[0])) / length
            depth = np.minimum(depth, left)
        inside |= depth > margin
    return inside


def particles_inside(out_dir, body, margin=0.0, index=-1):
    """(time, number of particles of body id ``body`` whose centres lie deeper than
    ``margin`` inside the FEM elements) at particle frame ``index``, matched to the element
    frame of the same time."""
    frame = read_frame(out_dir, index)
    times, x, hexes = node_paths(out_dir)
    k = int(np.argmin(np.abs(times - frame["time"])))
    if abs(times[k] - frame["time"]) > 1e-9 * (1.0 + abs(frame["time"])):
        raise ValueError(f"no element frame at t = {frame['time']}")
    points = frame["x"][frame["body"] == body, :2]
    return frame["time"], int(inside_quads(points, element_quads(x[k], hexes), margin).sum())


def added_mass_speed(mass=241.0, v0=6.15, rho=1000.0, half=0.25):
    """Von Karman: v = M v0 / (M + rho pi c^2 / 2) once the chines (half-width c) are wet
    (SI; kg per metre of span; defaults: seed 004 Sec. 4.4's wedge)."""
    return mass * v0 / (mass + rho * np.pi * half ** 2 / 2)


def momentum_theory(wetting, end=35.0, mass=241.0, v0=6.15, rho=1000.0, half=0.25,
                    deadrise=30.0, g=9.81):
    """(t in ms, v) of the wedge by the momentum balance (M + m_a) v = M (v0 + g t),
    m_a = rho pi c^2 / 2 with the wetted half-width c = min(wetting * zeta cot(deadrise),
    half) at the penetration zeta: von Karman's (wetting 1) or with Wagner's pile-up
    (pi / 2). Explicit Euler in 1 us steps (SI inside)."""
    cot, dt = 1.0 / np.tan(np.radians(deadrise)), 1e-6
    times = np.arange(0.0, end * 1e-3 + dt / 2, dt)
    v, zeta = np.empty(len(times)), 0.0
    for i, t in enumerate(times):
        c = min(wetting * zeta * cot, half)
        v[i] = mass * (v0 + g * t) / (mass + rho * np.pi * c * c / 2)
        zeta += v[i] * dt
    return times * 1e3, v
