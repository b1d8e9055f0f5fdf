"""Checkpoints for ``--restart``: every particle column plus the solver's scalars, in HDF5.

File layout of ``DIR/checkpoint_NNNNNN.h5`` (NNNNNN = step, at least six digits)::

    /            attrs: scalars (JSON string), n_total, ranks
    /columns/    one dataset per particle column, rows of all ranks, in creation order
    /case        scalar UTF-8 string (optional): JSON of the case the run was started
                 with (``text``, its validated form ``case``), for ``--restart`` to compare
    /NAME/       (optional) more row sets, as /columns/: the FEM bodies' ``elements`` and
                 ``nodes`` (pmpm.solver.fem_bodies)

Notes
-----
A checkpoint is written collectively to ``checkpoint_NNNNNN.h5.tmp``; only after every
rank has closed it does rank 0 fsync it and rename it to its final name, so a run that
dies while writing leaves the previous checkpoint as the latest complete one (a leftover
``.tmp`` never counts, and the next successful save removes it). Loading does not need the
number of ranks that wrote: each rank reads an equal contiguous share of the rows and the
solver then migrates particles to their owners.
"""
import glob
import json
import os
import re

import h5py
import numpy as np

from . import _collective as C
from ._files import dumps, fsync_path

_NAME = re.compile(r"^checkpoint_(\d+)\.h5$")


def checkpoint_path(directory, step):
    """Path of the checkpoint of ``step`` in ``directory``."""
    return os.path.join(os.fspath(directory), f"checkpoint_{int(step):06d}.h5")


def list_checkpoints(directory):
    """Complete checkpoints in ``directory`` as (step, path), oldest step first."""
    directory = os.fspath(directory)
    found = []
    for name in os.listdir(directory) if os.path.isdir(directory) else []:
        match = _NAME.match(name)
        if match:
            found.append((int(match.group(1)), os.path.join(directory, name)))
    return sorted(found)


def latest_checkpoint(directory):
    """Path of the newest complete checkpoint in ``directory``, or None."""
    found = list_checkpoints(directory)
    return found[-1][1] if found else None


def _publish(tmp, final, keep):
    """Rename a closed checkpoint into place and delete the ones no longer needed (rank 0)."""
    fsync_path(tmp)
    os.replace(tmp, final)
    directory = os.path.dirname(final)
    fsync_path(directory)
    step = int(_NAME.match(os.path.basename(final)).group(1))
    found = list_checkpoints(directory)
    older = [path for s, path in found if s < step]
    newer = [path for s, path in found if s > step]  # an abandoned run's, after a restart
    for path in older[:max(len(older) - (keep - 1), 0)] + newer:
        os.remove(path)
    for path in glob.glob(os.path.join(directory, "checkpoint_*.h5.tmp")):
        os.remove(path)


def save_checkpoint(directory, comm, scalars, columns, keep=2, case=None, groups=None):
    """Write a checkpoint of every rank's particles collectively, atomically, and rotate.

    Parameters
    ----------
    directory : str or os.PathLike
        Output directory (created if needed).
    comm : mpi4py.MPI.Comm
        Communicator of the writing ranks.
    scalars : dict
        JSON-able solver state taken from rank 0: must hold ``step``; typically also
        ``time``, ``dt``, the frame index, the next frame time and any nested dict.
        numpy scalars and arrays are converted; floats (infinity and NaN included) come
        back exactly.
    columns : dict of str to numpy.ndarray
        Every local particle column (1D and 2D, any int or float dtype), first axis =
        particle; ranks with no particles pass empty arrays.
    keep : int, optional
        Number of newest checkpoints to keep (default 2). Checkpoints of later steps than
        this one, left by an abandoned run after a restart, are deleted too.
    case : dict, optional
        JSON-able record of the case (rank 0's is stored as the ``/case`` dataset; see
        :func:`read_checkpoint_case`).
    groups : dict of str to dict of numpy.ndarray, optional
        More row sets, each written collectively like ``columns`` under ``/NAME/`` (the
        FEM bodies' elements and nodes); :func:`load_group` reads one back whole.

    Returns
    -------
    str
        Path of the checkpoint written, on every rank.
    """
    if keep < 1:
        raise ValueError(f"keep must be at least 1, got {keep}")
    text = dumps(C.bcast_root(comm, scalars), allow_nan=True)
    case_raw = None if case is None else dumps(C.bcast_root(comm, case)).encode("utf-8")
    final = checkpoint_path(directory, json.loads(text)["step"])
    tmp = final + ".tmp"
    os.makedirs(os.fspath(directory), exist_ok=True)
    layout = C.agree_layout(comm, columns)
    with h5py.File(tmp, "w", driver="mpio", comm=comm) as f:
        f.attrs.update({"scalars": text, "n_total": layout.total, "ranks": comm.size})
        datasets = C.create_columns(f.create_group("columns", track_order=True), layout)
        C.write_columns(datasets, layout, comm.rank, columns)
        for name, rows in (groups or {}).items():
            group_layout = C.agree_layout(comm, rows)
            group = f.create_group(name, track_order=True)
            C.write_columns(C.create_columns(group, group_layout), group_layout, comm.rank,
                            rows)
        if case_raw is not None:
            dset = f.create_dataset("case", shape=(), dtype=h5py.string_dtype(
                "utf-8", max(len(case_raw), 1)))
            C.write_root_only(dset, np.bytes_(case_raw), comm.rank)
    comm.Barrier()
    error = None
    if comm.rank == 0:
        try:
            _publish(tmp, final, keep)
        except OSError as exc:
            error = f"checkpoint {final}: {exc}"
    error = comm.bcast(error, root=0)
    if error:
        raise OSError(error)
    return final


def load_checkpoint(path, comm):
    """Read a checkpoint; each rank gets an equal contiguous share of the rows (collective).

    Parameters
    ----------
    path : str or os.PathLike
        A checkpoint file, e.g. from :func:`latest_checkpoint`.
    comm : mpi4py.MPI.Comm
        Communicator of the reading ranks (their number need not match the writers').

    Returns
    -------
    scalars : dict
        As saved.
    columns : dict of str to numpy.ndarray
        Rows ``[N*r//size, N*(r+1)//size)`` of every column on rank r, with the saved
        dtypes and trailing shapes, in the saved column order.
    """
    with h5py.File(os.fspath(path), "r", driver="mpio", comm=comm) as f:
        scalars = json.loads(f.attrs["scalars"])
        total = int(f.attrs["n_total"])
        start = total * comm.rank // comm.size
        count = total * (comm.rank + 1) // comm.size - start
        dxpl = C.collective_xfer()
        columns = {name: C.read_rows(dset, start, count, dxpl) if total else
                   np.empty(dset.shape, dset.dtype)        # no storage to read from
                   for name, dset in f["columns"].items()}
    return scalars, columns


def load_group(path, name):
    """Every row of the row set ``name`` saved with ``groups=`` (a dict of arrays), or
    None when the checkpoint has none. Not collective: each rank reads it whole."""
    with h5py.File(os.fspath(path), "r") as f:
        if name not in f:
            return None
        return {key: dset[()] if dset.shape[0] else np.empty(dset.shape, dset.dtype)
                for key, dset in f[name].items()}


def read_checkpoint_case(path):
    """The case record stored by :func:`save_checkpoint` (``case=``), or None when the
    checkpoint holds none (written before checkpoints kept their case). Not collective."""
    with h5py.File(os.fspath(path), "r") as f:
        if "case" not in f:
            return None
        raw = f["case"][()]
    return json.loads(raw.decode("utf-8") if isinstance(raw, bytes) else raw)


def checkpoint_problem(path):
    """Why the checkpoint at ``path`` cannot be restarted from (a short phrase), or None.

    Not collective (rank 0 asks before every rank reads). It opens the file, parses the
    scalars, and checks that every column has ``n_total`` rows stored within the file, so
    a truncated or overwritten file is found before any rank reads it; the values
    themselves carry no checksum."""
    try:
        size = os.path.getsize(path)
        with h5py.File(os.fspath(path), "r") as f:
            scalars = json.loads(f.attrs["scalars"])
            if not isinstance(scalars, dict) or "step" not in scalars:
                return "its scalars have no step"
            total = int(f.attrs["n_total"])
            columns = f["columns"]
            if "x" not in columns:
                return "it has no positions"
            for name, dset in columns.items():
                if dset.shape[:1] != (total,):
                    return f"column {name} has {dset.shape[:1]} rows, expected {total}"
                offset = dset.id.get_offset()
                if total and (offset is None or offset + dset.id.get_storage_size() > size):
                    return f"column {name} lies beyond the end of the file (truncated)"
            if "case" in f:
                f["case"][()]
    except (OSError, KeyError, ValueError, TypeError) as err:
        return str(err).splitlines()[0] if str(err) else type(err).__name__
    return None
