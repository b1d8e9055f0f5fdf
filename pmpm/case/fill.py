"""Filling a body's geometry with particles on a regular lattice.

The lattice spacing is d = grid.cell / particles_per_cell. An unrotated body uses the
lattice grid.min + (i + 1/2) d, aligned with the grid (2 particles per cell per direction
sit at the cell's quarter points). A rotated body is filled in its own frame on the
lattice reference_point + (i + 1/2) d, which is then rotated: a rotated box whose sides
are whole multiples of d gets exactly (side / d) particles per side. A ``points`` body is
not filled: its particles are its file's points (rotated if asked), as they are.
"""
import os

import numpy as np

from .errors import CaseError
from .mesh import CHUNK, MeshReadError, lattice_points_in_tets, read_tets
from .points import PointReadError, read_points
from .shapes import TOL, make_shape, reference_point, rotation_matrix
from .surface import SurfaceError, lattice_points_in_surface, read_surface

#: what reading a geometry's file may raise (file_problem says which key and why)
FILE_ERRORS = (MeshReadError, SurfaceError, PointReadError)


def fill_body(body, grid, case_dir="."):
    """Particles of a validated body: (positions float64 (n, 3), volumes float64 (n,)).

    ``case_dir`` is the folder mesh file names are relative to. Raises CaseError if a
    mesh, surface or point file cannot be used.
    """
    try:
        return fill_geometry(body["geometry"], grid, body["particles_per_cell"], case_dir)
    except FILE_ERRORS as error:
        key, message = file_problem(body["geometry"], error)
        raise CaseError([f"body {body['name']!r} geometry.{key}: {message}"]) from None


def file_problem(geometry, error):
    """(the geometry key at fault, the message) of a FILE_ERRORS ``error``."""
    if isinstance(error, PointReadError):
        return error.key, str(error)
    if isinstance(error, SurfaceError):
        return "file", f"{geometry['file']!r}: {error}"
    return "file", f"cannot read {geometry['file']!r}: {error}"


def fill_geometry(geometry, grid, particles_per_cell, case_dir="."):
    """(positions, volumes) of ``geometry`` filled at spacing grid.cell/particles_per_cell,
    and inside each of ``grid.windows`` at the window's spacing (cell / ratio /
    particles_per_cell): the particles of a window are the lattice points of its spacing
    inside it, those of the coarse grid the coarse lattice points outside every window.
    A points geometry gives its file's particles (rotated by ``rotate``)."""
    if geometry["type"] == "points":
        positions, volumes = read_points(geometry, case_dir)
        if geometry.get("rotate"):
            positions = rotate_points(positions, geometry["rotate"])
        return positions, volumes
    points = lattice_fill(geometry, grid, grid["cell"] / particles_per_cell, case_dir)
    coarse = np.ones(len(points), dtype=bool)
    for window in windows_of(grid):
        coarse &= ~in_window(points, window, grid)
    parts = [points[coarse]]
    volumes = [np.full(len(parts[0]), (grid["cell"] / particles_per_cell) ** 3)]
    for window in windows_of(grid):
        spacing = grid["cell"] / window["ratio"] / particles_per_cell
        fine = lattice_fill(geometry, grid, spacing, case_dir, clip=window)
        parts.append(fine[in_window(fine, window, grid)])
        volumes.append(np.full(len(parts[-1]), spacing ** 3))
    return np.concatenate(parts), np.concatenate(volumes)


def windows_of(grid):
    return grid.get("windows") or []


def in_window(points, window, grid):
    """Points inside the window's box (min <= x < max), as the solver assigns them to a
    grid: by their coarse cell."""
    cells = np.floor((points - np.asarray(grid["min"])) / grid["cell"])
    lo = np.rint((np.asarray(window["min"]) - grid["min"]) / grid["cell"])
    hi = np.rint((np.asarray(window["max"]) - grid["min"]) / grid["cell"])
    return np.all((cells >= lo) & (cells < hi), axis=1)


def lattice_fill(geometry, grid, spacing, case_dir, clip=None):
    """Lattice points of ``spacing`` inside ``geometry``, rotated and cut at symmetry
    planes; ``clip`` (a box with min, max) limits the search for an unrotated body."""
    rotate = geometry.get("rotate")
    anchor = reference_point(geometry) if rotate else grid["min"]
    points = points_inside(geometry, np.asarray(anchor, float), spacing, case_dir,
                           None if rotate else clip)
    if rotate:
        points = rotate_points(points, rotate)
    return clip_at_symmetry_planes(points, grid)


def clip_at_symmetry_planes(points, grid):
    """Drop the particles beyond a face declared ``symmetry``: a quarter or half model is
    the full body cut by its symmetry planes (which act as slip faces)."""
    keep = np.ones(len(points), dtype=bool)
    for face, kind in grid.get("boundary", {}).items():
        if kind != "symmetry":
            continue
        axis = "xyz".index(face[0])
        if face[1] == "-":
            keep &= points[:, axis] >= grid["min"][axis]
        else:
            keep &= points[:, axis] < grid["max"][axis]
    return points[keep]


def points_inside(geometry, anchor, spacing, case_dir, clip=None):
    """Lattice points anchor + (i + 1/2) spacing inside the unrotated geometry (and inside
    the box ``clip``, if given, with a margin of one spacing)."""
    if geometry["type"] == "mesh":
        tets = read_tets(os.path.join(case_dir, geometry["file"]),
                         geometry["scale"], geometry["translate"])
        return lattice_points_in_tets(tets, anchor, spacing)
    if geometry["type"] == "surface":
        surface = read_surface(os.path.join(case_dir, geometry["file"]),
                               geometry["scale"], geometry["translate"])
        box = None if clip is None else (np.asarray(clip["min"]) - spacing,
                                         np.asarray(clip["max"]) + spacing)
        return lattice_points_in_surface(*surface, anchor, spacing, box)
    shape = make_shape(geometry)
    lo, hi = (np.asarray(b, float) for b in shape.bounds())
    if clip is not None:
        lo = np.maximum(lo, np.asarray(clip["min"]) - spacing)
        hi = np.minimum(hi, np.asarray(clip["max"]) + spacing)
        if np.any(lo > hi):
            return np.zeros((0, 3))
    kept = [points[shape.contains(points)] for points in lattice_slabs(lo, hi, anchor, spacing)]
    return np.concatenate(kept + [np.zeros((0, 3))])


def lattice_slabs(lo, hi, anchor, spacing, max_points=CHUNK):
    """The lattice points anchor + (i + 1/2) spacing within [lo, hi], as (n, 3) arrays of
    at most about ``max_points`` each (slabs of whole x planes; x slowest, z fastest)."""
    first = np.ceil((lo - anchor) / spacing - 0.5 - TOL).astype(np.int64)
    last = np.floor((hi - anchor) / spacing - 0.5 + TOL).astype(np.int64)
    axes = [anchor[a] + (np.arange(first[a], last[a] + 1) + 0.5) * spacing for a in range(3)]
    per_plane = max(len(axes[1]) * len(axes[2]), 1)
    step = max(max_points // per_plane, 1)
    for start in range(0, len(axes[0]), step):
        mesh = np.meshgrid(axes[0][start:start + step], axes[1], axes[2], indexing="ij")
        yield np.stack([m.ravel() for m in mesh], axis=1)


def rotate_points(points, rotate):
    """Points turned by ``rotate`` = {axis, angle_deg, origin} about its origin."""
    origin = np.asarray(rotate["origin"], float)
    matrix = rotation_matrix(rotate["axis"], rotate["angle_deg"])
    return origin + (points - origin) @ matrix.T
