"""A structure-of-arrays store of rows parameterised by a column table, shared by every
kind of material point: particles today, finite elements tomorrow.

A column table maps name -> (dtype, components per row). Columns that several kinds of
store share are declared once as a group (:data:`MATERIAL_GROUP`, the material state
the constitutive kernels update) and included by name in each store's table with
:func:`column_table`. A store keeps one contiguous array per column, first axis the row,
as an attribute of that name; every column travels with its row when rows migrate, are
re-sorted or are checkpointed.
"""
import numpy as np

from pmpm.materials.state import MATERIAL_COLUMNS, MaterialState

#: the material state of a point (see pmpm/materials/state.py), in MaterialState order
MATERIAL_GROUP = {name: (np.float64, {"stress": 6, "F": 9}.get(name, 1))
                  for name in MATERIAL_COLUMNS}


def column_table(entries, groups=()):
    """A column table from a store's own columns and the groups it includes.

    ``entries`` lists the columns in their order: ``(name, dtype, width)`` for a column
    of this store only, or a bare name to place a group's column there. The columns of
    each group that ``entries`` does not name follow at the end, in group order, so a
    store including a group always gets all of it.
    """
    pooled = {}
    for group in groups:
        pooled.update(group)
    table = {}
    for entry in entries:
        name = entry if isinstance(entry, str) else entry[0]
        if name in table or (name in pooled) != isinstance(entry, str):
            raise ValueError(f"column {name!r}: named twice, or not as its group has it")
        table[name] = pooled[name] if isinstance(entry, str) else tuple(entry[1:])
    for name, spec in pooled.items():
        table.setdefault(name, spec)
    return table


class ColumnStore:
    """The rows of one kind that a rank owns, one array per column of :attr:`COLUMNS`.

    A kind of store is a subclass that sets ``COLUMNS`` (built with :func:`column_table`);
    its columns are attributes (``store.x``, ``store.stress``...). Methods that change
    the rows replace columns one at a time, so the extra memory is one column, never the
    whole store, and any view taken earlier (such as :attr:`material`) goes stale.
    """

    COLUMNS = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        clash = sorted(name for name in cls.COLUMNS if hasattr(ColumnStore, name))
        if clash:
            raise TypeError(f"{cls.__name__}: columns {clash} hide ColumnStore attributes")

    def __init__(self, columns):
        missing = set(self.COLUMNS) - set(columns)
        if missing:
            raise ValueError(f"{type(self).__name__} columns missing: {sorted(missing)}")
        self.set_columns(columns)

    @classmethod
    def empty_column(cls, name, n):
        dtype, width = cls.COLUMNS[name]
        return np.zeros((n, width) if width > 1 else n, dtype=dtype)

    @classmethod
    def empty(cls, n=0):
        return cls({name: cls.empty_column(name, n) for name in cls.COLUMNS})

    @classmethod
    def row_dtype(cls):
        """A numpy structured dtype holding one row of every column (aligned fields)."""
        return np.dtype([(name, dtype, (width,) if width > 1 else ())
                         for name, (dtype, width) in cls.COLUMNS.items()], align=True)

    @classmethod
    def bytes_per_row(cls):
        return sum(np.dtype(dtype).itemsize * width for dtype, width in cls.COLUMNS.values())

    def set_columns(self, columns):
        for name in self.COLUMNS:
            self.replace_column(name, columns[name])

    def replace_column(self, name, values):
        dtype, _ = self.COLUMNS[name]
        setattr(self, name, np.ascontiguousarray(values, dtype=dtype))

    @property
    def n(self):
        return len(getattr(self, next(iter(self.COLUMNS))))

    def columns(self):
        return {name: getattr(self, name) for name in self.COLUMNS}

    def nbytes(self):
        return sum(col.nbytes for col in self.columns().values())

    @property
    def material(self):
        """The material columns as one :class:`MaterialState` of the current arrays
        (built on each access: the arrays are replaced when rows move)."""
        return MaterialState(*(getattr(self, name) for name in MATERIAL_COLUMNS))

    def rows(self, index):
        """The rows ``index`` packed as one structured array of :meth:`row_dtype`."""
        index = _row_indices(index, self.n)
        packed = np.empty(len(index), self.row_dtype())
        for name in self.COLUMNS:
            packed[name] = np.take(getattr(self, name), index, axis=0)
        return packed

    def take(self, index, before=None, after=None):
        """Keep only the rows ``index`` (bool mask or integer array), in that order;
        with ``before`` and ``after`` (structured rows as from :meth:`rows`, or dicts of
        columns), the rows become ``before + kept + after``."""
        index = _row_indices(index, self.n)
        for name in self.COLUMNS:
            self.replace_column(name, _spliced(getattr(self, name), index, before, after,
                                               name))

    def append(self, other_columns):
        """Add rows at the end (``other_columns``: name -> array), one column at a time."""
        for name in self.COLUMNS:
            dtype, _ = self.COLUMNS[name]
            joined = np.concatenate([getattr(self, name), other_columns[name]]).astype(
                dtype, copy=False)
            setattr(self, name, joined)


def _row_indices(index, n):
    """``index`` as int64 row numbers in [0, n) (a bool mask must have n entries)."""
    index = np.asarray(index)
    if index.dtype == bool:
        if index.shape != (n,):
            raise IndexError(f"row mask of shape {index.shape} for {n} rows")
        return np.flatnonzero(index)
    index = index.astype(np.int64, copy=False).reshape(-1)
    low, high = (index.min(), index.max()) if index.size else (0, -1)
    if low < -n or high >= n:
        raise IndexError(f"row index out of range for {n} rows")
    return np.where(index < 0, index + n, index) if low < 0 else index


def _spliced(column, index, before, after, name):
    """A new array: rows ``before[name]``, then ``column[index]``, then ``after[name]``."""
    if before is None and after is None:
        return np.take(column, index, axis=0)
    head = before[name] if before is not None else column[:0]
    tail = after[name] if after is not None else column[:0]
    out = np.empty((len(head) + len(index) + len(tail),) + column.shape[1:], column.dtype)
    out[:len(head)] = head
    np.take(column, index, axis=0, out=out[len(head):len(head) + len(index)], mode="clip")
    out[len(head) + len(index):] = tail
    return out
