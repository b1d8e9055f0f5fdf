"""Collective HDF5 helpers: agree on a column layout across ranks, write and read row blocks.

Every function here is collective over ``comm`` (an mpi4py communicator passed in; this
module never imports mpi4py). Ranks that hold no rows take part in every call.

Notes
-----
Rows are laid out rank after rank: rank r writes rows ``[offset_r, offset_r + n_r)`` with
``offset_r = n_0 + ... + n_(r-1)`` (an exclusive scan of the counts). The counts travel in
the same gather/broadcast that checks the column names, dtypes and trailing shapes, so one
frame costs two small collectives before the data transfer. A writer with its own layout
(the particle frames group rows by body) writes with :func:`write_row_ranges`: each rank's
rows go into several file ranges in one collective call. Data transfers use collective
MPI-IO; a rank with no rows selects nothing in the file and in memory but still calls
``H5Dwrite``/``H5Dread``, as collective mode requires (h5py's slicing skips the call for an
empty selection, which would hang the other ranks, so the low-level API is used).
"""
from dataclasses import dataclass

import numpy as np
from h5py import h5fd, h5p, h5s


@dataclass(frozen=True)
class ColumnSpec:
    """Name, numpy dtype string and shape after the first axis of one column."""

    name: str
    dtype: str
    trailing: tuple


@dataclass(frozen=True)
class Layout:
    """Columns and per-rank row counts that every rank agreed on."""

    specs: tuple
    counts: tuple

    @property
    def total(self):
        """Global number of rows."""
        return sum(self.counts)

    def offset(self, rank):
        """First global row of ``rank``."""
        return sum(self.counts[:rank])


def _local_specs(columns):
    """(row count, specs, error or None) of this rank's columns."""
    specs, lengths = [], set()
    for name, array in columns.items():
        if not (hasattr(array, "shape") and hasattr(array, "dtype")):
            array = np.asarray(array)     # a deferred column says its shape unread
        if array.ndim == 0:
            return 0, [], f"column {name!r} is a scalar, not an array of rows"
        specs.append(ColumnSpec(str(name), array.dtype.str, tuple(array.shape[1:])))
        lengths.add(array.shape[0])
    if len(lengths) > 1:
        return 0, specs, f"columns differ in length: {sorted(lengths)}"
    return (lengths.pop() if lengths else 0), specs, None


def _check_gathered(gathered):
    """Reference specs and the first disagreement among ranks' (n, specs, error) tuples.

    Ranks with no rows must name the same columns but may carry any dtype or shape: their
    empty arrays are never written.
    """
    for rank, (_, _, error) in enumerate(gathered):
        if error:
            return None, f"rank {rank}: {error}"
    full = [specs for n, specs, _ in gathered if n > 0]
    reference = full[0] if full else gathered[0][1]
    names = [spec.name for spec in reference]
    for rank, (n, specs, _) in enumerate(gathered):
        if sorted(spec.name for spec in specs) != sorted(names):
            have = sorted(spec.name for spec in specs)
            return None, f"rank {rank} has columns {have}, expected {sorted(names)}"
        if n > 0 and sorted(specs, key=lambda s: s.name) != sorted(reference, key=lambda s: s.name):
            return None, f"rank {rank} column dtypes or shapes differ from the other ranks'"
    return tuple(reference), None


def agree_layout(comm, columns):
    """Check that all ranks hold the same columns and share out the rows (collective).

    Parameters
    ----------
    comm : mpi4py.MPI.Comm
        Communicator of the ranks that write.
    columns : dict of str to numpy.ndarray
        This rank's columns, each with the particle index as its first axis.

    Returns
    -------
    Layout
        The same on every rank; column order is that of the first rank holding rows.

    Raises
    ------
    ValueError
        On every rank alike, when the ranks disagree (names, dtypes, trailing shapes) or a
        rank's columns differ in length.
    """
    gathered = comm.gather(_local_specs(columns), root=0)
    result = None
    if comm.rank == 0:
        specs, error = _check_gathered(gathered)
        result = (specs, tuple(n for n, _, _ in gathered), error)
    specs, counts, error = comm.bcast(result, root=0)
    if error:
        raise ValueError(error)
    return Layout(specs, counts)


def collective_xfer():
    """A dataset transfer property list set to collective MPI-IO."""
    dxpl = h5p.create(h5p.DATASET_XFER)
    dxpl.set_dxpl_mpio(h5fd.MPIO_COLLECTIVE)
    return dxpl


def create_columns(group, layout, **kwargs):
    """Create one dataset per column, sized by the global row count (collective).

    Returns
    -------
    dict of str to h5py.Dataset
    """
    datasets = {}
    for spec in layout.specs:
        shape = (layout.total,) + spec.trailing
        datasets[spec.name] = group.create_dataset(
            spec.name, shape=shape, dtype=np.dtype(spec.dtype), fill_time="never", **kwargs)
    return datasets


def _selection(dset, start, shape):
    """File and memory dataspaces selecting ``shape`` rows from ``start``, or nothing."""
    fspace = dset.id.get_space()
    if shape[0] == 0:
        fspace.select_none()
        mspace = h5s.create_simple((1,) + tuple(shape[1:]))
        mspace.select_none()
        return fspace, mspace
    fspace.select_hyperslab((start,) + (0,) * (len(shape) - 1), tuple(shape))
    return fspace, h5s.create_simple(tuple(shape))


def write_rows(dset, start, rows, dxpl):
    """Write this rank's ``rows`` at global row ``start``; an empty block still takes part."""
    rows = np.asarray(rows)
    trailing = dset.shape[1:]
    if rows.shape[0] == 0:
        rows = np.zeros((1,) + trailing, dtype=dset.dtype)
        fspace, mspace = _selection(dset, start, (0,) + trailing)
    else:
        rows = np.ascontiguousarray(rows, dtype=dset.dtype)
        fspace, mspace = _selection(dset, start, rows.shape)
    dset.id.write(mspace, fspace, rows, dxpl=dxpl)


def write_row_ranges(dset, starts, counts, rows, dxpl):
    """Write this rank's ``rows`` into the file row ranges ``[starts[k], starts[k] + counts[k])``
    in one collective call: the ranges must be increasing and disjoint, and ``rows`` holds
    ``sum(counts)`` rows, range after range (HDF5 fills a union of hyperslabs in file
    order). A rank with no rows still takes part."""
    trailing = dset.shape[1:]
    ranges = [(int(s), int(c)) for s, c in zip(starts, counts) if c > 0]
    if not ranges:
        write_rows(dset, 0, np.zeros((0,) + trailing, dtype=dset.dtype), dxpl)
        return
    rows = np.ascontiguousarray(rows, dtype=dset.dtype)
    fspace = dset.id.get_space()
    for k, (start, count) in enumerate(ranges):
        fspace.select_hyperslab((start,) + (0,) * len(trailing), (count,) + trailing,
                                op=h5s.SELECT_SET if k == 0 else h5s.SELECT_OR)
    dset.id.write(h5s.create_simple(rows.shape), fspace, rows, dxpl=dxpl)


def read_rows(dset, start, count, dxpl):
    """Read ``count`` rows from global row ``start``; ``count == 0`` still takes part."""
    trailing = dset.shape[1:]
    out = np.empty((max(count, 1),) + trailing, dtype=dset.dtype)
    fspace, mspace = _selection(dset, start, (count,) + trailing)
    dset.id.read(mspace, fspace, out, dxpl=dxpl)
    return out[:count]


def write_columns(datasets, layout, rank, columns):
    """Write every column of this rank's rows into its hyperslab (collective)."""
    if layout.total == 0:
        return
    dxpl, start = collective_xfer(), layout.offset(rank)
    for spec in layout.specs:
        write_rows(datasets[spec.name], start, columns[spec.name], dxpl)


def write_root_only(dset, value, rank):
    """Write a whole (small) dataset from rank 0's ``value``; other ranks select nothing."""
    fspace = dset.id.get_space()
    mspace = h5s.create(h5s.SCALAR) if dset.shape == () else h5s.create_simple(dset.shape)
    if rank != 0:
        fspace.select_none()
        mspace.select_none()
    buf = np.asarray(value, dtype=dset.dtype).reshape(dset.shape)
    dset.id.write(mspace, fspace, buf, mtype=dset.id.get_type(), dxpl=collective_xfer())


def bcast_root(comm, value):
    """Rank 0's ``value`` on every rank, so that metadata writes are identical."""
    return comm.bcast(value if comm.rank == 0 else None, root=0)
