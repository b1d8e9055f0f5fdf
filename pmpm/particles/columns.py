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
    the rows give every column a new array object, so any view taken earlier (such as
    :attr:`material`) goes stale: it may keep the old rows or, where the rows moved in
    place (:meth:`take` with the order kept, :meth:`append`), see them overwritten. Each
    column is a view of a buffer with spare rows at both ends (about 1/32 of the rows
    each side), so that the few rows that leave or arrive in a step cost in proportion
    to themselves; a full copy (a sort) goes one column at a time, so the extra memory
    is one column, never the whole store.
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
        columns), the rows become ``before + kept + after``.

        Rows kept in their order (a mask: migration, lost particles) are moved in place
        in the columns' buffers, and ``before`` and ``after`` go into the spare rows at
        either end (:class:`_Buffers`): the cost is that of the rows that move, not of
        the store. A reordering (a sort) copies every column into fresh buffers."""
        index = _row_indices(index, self.n)
        before, after = _own_copy(self, before), _own_copy(self, after)
        if not (_increasing(index) and self._splice_in_place(index, before, after)):
            self._rebuild(index, before, after)

    def append(self, other_columns):
        """Add rows at the end (``other_columns``: name -> array), into the spare rows
        behind the columns where they fit, else into fresh buffers."""
        other_columns = _own_copy(self, other_columns)
        if not self._splice_in_place(None, None, other_columns):
            self._rebuild(np.arange(self.n, dtype=np.int64), None, other_columns)

    # -- the buffers behind the columns -------------------------------------------------
    def _live_buffers(self):
        """The buffers the columns are views of, or None when some column was replaced
        since (set_columns, replace_column, a plain attribute): then the next change
        copies the store once into fresh buffers."""
        buffers = getattr(self, "_buffers", None)
        if buffers is None or any(getattr(self, name) is not buffers.views[name]
                                  for name in self.COLUMNS):
            return None
        return buffers

    def _splice_in_place(self, index, before, after):
        """``before + rows index + after`` in the live buffers, if they hold it and the
        rows that move are at most :data:`MOST_MOVED` of the result. ``index``: kept
        rows, increasing (None: all). Returns whether it was done."""
        buffers = self._live_buffers()
        if buffers is None:
            return False
        plan = _Plan(self.n, index, _length(before), _length(after), buffers)
        if not plan.fits():
            return False
        for name in self.COLUMNS:
            buffers.views[name] = plan.apply(buffers.arrays[name], name, before, after)
            setattr(self, name, buffers.views[name])
        buffers.start, buffers.stop = plan.new_start, plan.new_stop
        return True

    def _rebuild(self, index, before, after):
        """Every column copied into a fresh buffer with spare rows at both ends, one at a
        time: the old buffers are let go first, so each goes when its column is
        replaced (the extra memory is one column)."""
        n = _length(before) + len(index) + _length(after)
        spare = spare_rows(n)
        self._buffers = None
        buffers = _Buffers(spare, spare + n)
        for name in self.COLUMNS:
            column = getattr(self, name)
            array = np.empty((n + 2 * spare,) + column.shape[1:], self.COLUMNS[name][0])
            view = array[spare:spare + n]
            _splice_into(view, column, index, before, after, name)
            buffers.arrays[name], buffers.views[name] = array, view
            setattr(self, name, view)
        self._buffers = buffers


#: spare rows at each end of a column's buffer: a fraction of the rows, at least a few
#: (np.empty leaves them unwritten, so a large buffer's spare pages are not resident
#: until arrivals use them)
SPARE_FRACTION, SPARE_MIN = 32, 64
#: in place only while the rows that move are at most this share of the result; beyond
#: it a fresh copy costs the same and renews the spare rows
MOST_MOVED = 0.5


def spare_rows(n):
    return max(SPARE_MIN, n // SPARE_FRACTION)


class _Buffers:
    """The arrays behind a store's columns: each column is ``arrays[name][start:stop]``,
    the view ``views[name]`` (kept to tell when a column was replaced)."""

    def __init__(self, start, stop):
        self.arrays, self.views = {}, {}
        self.start, self.stop = start, stop

    @property
    def capacity(self):
        return len(next(iter(self.arrays.values())))


class _Plan:
    """How rows ``index`` (increasing; None: all) of ``n`` close up in place: the kept
    rows left of the widest run of kept rows shift right onto it, those right of it
    shift left, so what moves is the rows outside that run (few when the removed rows
    are near the ends, as the rows leaving a slab are when sorted with its axis
    slowest). ``n_before`` rows then go just before, ``n_after`` just after."""

    def __init__(self, n, index, n_before, n_after, buffers):
        start = buffers.start
        if index is None or len(index) == n:
            left = right = np.zeros(0, np.int64)
            run = (0, n)
        else:
            gone = np.ones(n, bool)
            gone[index] = False
            edges = np.concatenate([[-1], np.flatnonzero(gone), [n]])
            widest = int(np.argmax(np.diff(edges)))
            run = (int(edges[widest]) + 1, int(edges[widest + 1]))
            cut = np.searchsorted(index, run)
            left, right = index[:cut[0]], index[cut[1]:]
        self.left_from, self.right_from = left + start, right + start
        self.left_to = start + run[0] - len(left)
        self.right_to = start + run[1]
        self.new_start = self.left_to - n_before
        self.new_stop = self.right_to + len(right) + n_after
        self.moved = len(left) + len(right)
        self.capacity = buffers.capacity

    def fits(self):
        n_new = self.new_stop - self.new_start
        return (self.new_start >= 0 and self.new_stop <= self.capacity
                and self.moved <= MOST_MOVED * n_new
                and self.capacity <= n_new + 4 * spare_rows(n_new))

    def apply(self, array, name, before, after):
        """Move one column's rows in ``array`` and write the new ones; returns the view."""
        if len(self.left_from):
            array[self.left_to:self.left_to + len(self.left_from)] = array[self.left_from]
        if len(self.right_from):
            array[self.right_to:self.right_to + len(self.right_from)] = array[self.right_from]
        if before is not None:
            array[self.new_start:self.left_to] = before[name]
        if after is not None:
            array[self.new_stop - _length(after):self.new_stop] = after[name]
        return array[self.new_start:self.new_stop]


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


def _increasing(index):
    return len(index) < 2 or bool(np.all(index[1:] > index[:-1]))


def _length(rows):
    """Rows in ``before``/``after`` (a structured array or a dict of columns; None: 0)."""
    if rows is None:
        return 0
    return len(rows) if isinstance(rows, np.ndarray) else len(next(iter(rows.values())))


def _own_copy(store, rows):
    """``rows`` (structured array or dict of columns), copied where it shares memory
    with the store's buffers, which the in-place splice overwrites."""
    buffers = getattr(store, "_buffers", None)
    if rows is None or buffers is None:
        return rows
    arrays = buffers.arrays.values()
    if isinstance(rows, np.ndarray):
        return rows.copy() if any(np.may_share_memory(rows, a) for a in arrays) else rows
    return {name: (np.array(col) if any(np.may_share_memory(col, a) for a in arrays)
                   else col) for name, col in rows.items()}


def _splice_into(out, column, index, before, after, name):
    """Fill ``out``: rows ``before[name]``, then ``column[index]``, then ``after[name]``."""
    head = _length(before)
    tail = _length(after)
    if head:
        out[:head] = before[name]
    np.take(column, index, axis=0, out=out[head:head + len(index)], mode="clip")
    if tail:
        out[head + len(index):] = after[name]
