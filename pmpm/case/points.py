"""Particles read from a point file (``geometry: {type: points}``): a CSV table, an HDF5
file or a point cloud meshio reads (.vtu, .vtk, .ply, ...), each point one particle.

An analyst who has particles from another code (a converted LS-DYNA SPH deck, a Uintah
``.ups`` particle file exported as a table, a scanned part) gives them as they are: the
particles are the file's points, in the file's order, placed at ``scale * x +
translate``; each particle's volume is the file's ``volume`` column (scaled by
``scale^3``) or ``spacing^3``.
"""
import os

import numpy as np

from .mesh import MeshReadError, _read_mesh

CSV_SUFFIXES = (".csv", ".txt")
HDF5_SUFFIXES = (".h5", ".hdf5", ".hdf")
#: column names of the coordinates in a CSV file when the case names none
CSV_COORDINATES = ["x", "y", "z"]


class PointReadError(Exception):
    """A point file that is missing or unreadable, or lacks a named column or dataset.
    ``key`` is the geometry key the problem belongs to (``file``, ``coordinates``,
    ``volume``)."""

    def __init__(self, key, message):
        super().__init__(message)
        self.key = key


def file_kind(name):
    """'csv', 'hdf5' or 'meshio' from the file's suffix."""
    suffix = os.path.splitext(name)[1].lower()
    if suffix in CSV_SUFFIXES:
        return "csv"
    return "hdf5" if suffix in HDF5_SUFFIXES else "meshio"


def read_points(geometry, case_dir="."):
    """(positions float64 (n, 3), volumes float64 (n,)) of a validated points geometry.
    Raises PointReadError naming the key at fault; volumes that are not finite and > 0
    are refused (with the first such row) under ``volume``."""
    path = os.path.join(case_dir, geometry["file"])
    if not os.path.isfile(path):
        raise PointReadError("file", f"cannot read {geometry['file']!r}: no such file")
    reader = {"csv": _read_csv, "hdf5": _read_hdf5, "meshio": _read_cloud}
    positions, volumes = reader[file_kind(path)](path, geometry)
    scale = geometry["scale"]
    positions = positions * scale + np.asarray(geometry["translate"], float)
    if volumes is None:
        volumes = np.full(len(positions), float(geometry["spacing"]) ** 3)
    else:
        volumes = volumes * scale ** 3
    _check_values(positions, volumes, geometry)
    return positions, volumes


def _check_values(positions, volumes, geometry):
    if len(positions) == 0:
        raise PointReadError("file", f"{geometry['file']!r} holds no point")
    bad = np.flatnonzero(~np.isfinite(positions).all(axis=1))
    if len(bad):
        raise PointReadError("file", f"point {bad[0]} of {geometry['file']!r} (of "
                             f"{len(bad)} such) has coordinates that are not finite")
    bad = np.flatnonzero(~(volumes > 0) | ~np.isfinite(volumes))
    if len(bad):
        raise PointReadError("volume", f"point {bad[0]} of {geometry['file']!r} (of "
                             f"{len(bad)} such) has volume {volumes[bad[0]]:g}: every "
                             f"volume must be finite and > 0")


def _read_csv(path, geometry):
    """Columns by the header's names; the coordinates are ``coordinates`` (default x, y,
    z), the volume the column ``volume`` names. The rows are parsed by numpy (a million
    points in about a second)."""
    names = geometry.get("coordinates", CSV_COORDINATES)
    if len(names) != 3:
        raise PointReadError("coordinates", "name the three columns of x, y and z of a "
                             f"CSV file, not {len(names)}")
    wanted = list(names) + ([geometry["volume"]] if "volume" in geometry else [])
    try:
        with open(path, encoding="utf-8-sig") as f:
            header, skipped = _header(f, geometry)
            index = _column_index(header, wanted, geometry)
            table = np.loadtxt(f, delimiter=",", usecols=index, ndmin=2, comments="#")
    except (OSError, UnicodeDecodeError) as error:
        raise PointReadError("file", f"cannot read {geometry['file']!r}: {error}") from None
    except ValueError as error:
        raise PointReadError("file", f"{geometry['file']!r}: expected numbers in columns "
                             f"{', '.join(wanted)} below the header (line {skipped}): "
                             f"{error}") from None
    table = table.reshape(-1, len(wanted))
    return table[:, :3], (table[:, 3] if "volume" in geometry else None)


def _header(f, geometry):
    """The column names of the first line that is neither empty nor a # comment, and
    the number of lines read."""
    for count, line in enumerate(f, 1):
        if line.strip() and not line.lstrip().startswith("#"):
            return [name.strip() for name in line.split(",")], count
    raise PointReadError("file", f"{geometry['file']!r} is empty (a header of column "
                         f"names and one row per point are expected)")


def _column_index(header, wanted, geometry):
    """The positions in ``header`` of the columns ``wanted``."""
    for k, name in enumerate(wanted):
        if name not in header:
            key = "volume" if k == 3 else "coordinates"
            raise PointReadError(key, f"{geometry['file']!r} has no column {name!r} "
                                 f"(its header: {', '.join(header)})")
    return [header.index(name) for name in wanted]


def _read_hdf5(path, geometry):
    """``coordinates``: one (n, 3) dataset or three (n,) datasets; ``volume``: an (n,)
    dataset."""
    import h5py
    names = geometry.get("coordinates")
    if not names:
        raise PointReadError("coordinates", "name the HDF5 dataset of the positions (one "
                             "(n, 3) dataset, or three (n,) datasets x, y, z)")
    try:
        with h5py.File(path, "r") as f:
            positions = _hdf5_positions(f, names, geometry)
            volumes = None
            if "volume" in geometry:
                volumes = _dataset(f, geometry["volume"], "volume", geometry).ravel()
    except OSError as error:
        raise PointReadError("file", f"cannot read {geometry['file']!r}: {error}") from None
    if volumes is not None and len(volumes) != len(positions):
        raise PointReadError("volume", f"dataset {geometry['volume']!r} holds "
                             f"{len(volumes)} values for {len(positions)} points")
    return positions, volumes


def _hdf5_positions(f, names, geometry):
    if len(names) == 1:
        positions = _dataset(f, names[0], "coordinates", geometry)
        if positions.ndim != 2 or positions.shape[1] != 3:
            raise PointReadError("coordinates", f"dataset {names[0]!r} has shape "
                                 f"{positions.shape}, not (n, 3)")
        return positions
    if len(names) != 3:
        raise PointReadError("coordinates", f"name one (n, 3) dataset or three (n,) "
                             f"datasets, not {len(names)}")
    columns = [_dataset(f, name, "coordinates", geometry).ravel() for name in names]
    if len({len(c) for c in columns}) != 1:
        raise PointReadError("coordinates", "the datasets " + ", ".join(names) +
                             " hold " + ", ".join(str(len(c)) for c in columns) + " values")
    return np.stack(columns, axis=1)


def _dataset(f, name, key, geometry):
    if name not in f or not hasattr(f[name], "shape"):
        known = []
        f.visititems(lambda n, obj: known.append(n) if hasattr(obj, "shape") else None)
        raise PointReadError(key, f"{geometry['file']!r} has no dataset {name!r} (its "
                             f"datasets: {', '.join(known) or 'none'})")
    return np.asarray(f[name][()], float)


def _read_cloud(path, geometry):
    """A meshio file's points (its cells are not used); the volume is the point data
    array ``volume`` names."""
    if "coordinates" in geometry:
        raise PointReadError("coordinates", f"{geometry['file']!r} is read by meshio, "
                             f"whose points are the positions: leave coordinates out")
    try:
        mesh = _read_mesh(path)
    except MeshReadError as error:
        raise PointReadError("file", f"cannot read {geometry['file']!r}: {error}") from None
    positions = np.asarray(mesh.points, float)
    if positions.ndim != 2 or positions.shape[1] != 3:
        raise PointReadError("file", f"the points of {geometry['file']!r} are not 3D "
                             f"(shape {positions.shape})")
    if "volume" not in geometry:
        return positions, None
    data = mesh.point_data or {}
    if geometry["volume"] not in data:
        raise PointReadError("volume", f"{geometry['file']!r} has no point data "
                             f"{geometry['volume']!r} (its point data: "
                             f"{', '.join(data) or 'none'})")
    return positions, np.asarray(data[geometry["volume"]], float).ravel()
