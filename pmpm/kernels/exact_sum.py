"""Exact sums whose bits do not depend on the rank count or the order of the terms.

An accumulator column holds the exact sum of the terms added so far as a non-overlapping
expansion (Shewchuk's partials, as Python's ``math.fsum`` keeps them): a few doubles
whose exact sum is the exact sum of the terms. Rounding happens once, at the end, when
every rank's partials of a column are folded by ``math.fsum`` (correctly rounded: the
same double whatever the order or the split of the terms over ranks;
:func:`pmpm.solver.observe.exact_totals`). So an output column summed this way is the
same on 1 and N ranks as long as each term is (a particle's ``m x``, an FE node's, a
contact node's impulse), with no canonical order to keep.

An accumulator is a float array (columns, :data:`WIDTH`): per column the number of
partials, the sum of the non-finite terms (inf or NaN: kept apart, so that they give
the column's inf or NaN and do not spoil the partials) and the partials, smallest first.
The cost: a handful of adds per term and partial; columns of same-signed terms keep
two or three partials.
"""
import numpy as np
from numba import njit
from numba.extending import overload

#: the most partials a column can need: a non-overlapping expansion of doubles spans at
#: most the 2098 binary places from 2**-1074 to 2**1024, 53 per partial (40), and more
HEAD = 2
PARTS = 48
WIDTH = HEAD + PARTS


def zeros(n_columns):
    """An empty accumulator of ``n_columns`` columns."""
    return np.zeros((int(n_columns), WIDTH))


@njit(cache=True, inline="always")
def add(acc, c, x):
    """Add the term ``x`` exactly to column ``c`` of ``acc``."""
    add_to(acc[c], x)


@njit(cache=True, inline="always")
def add_to(column, x):
    """Add the term ``x`` exactly to one accumulator ``column`` (WIDTH,) (msum: each
    partial, from the smallest, is combined with x by a two-sum; the non-zero low parts
    are kept)."""
    if not np.isfinite(x):
        column[1] += x
        return
    n = np.int64(column[0])
    kept = 0
    for j in range(n):
        y = column[HEAD + j]
        if abs(x) < abs(y):
            x, y = y, x
        high = x + y
        low = y - (high - x)
        if low != 0.0:
            column[HEAD + kept] = low
            kept += 1
        x = high
    column[HEAD + kept] = x
    column[0] = kept + 1


def put2(out, i, j, x):
    """``out[i, j] += x`` for a float array (2-D), exactly for an accumulator of that
    shape (3-D, the partials last): a kernel that takes either sums plainly or exactly
    (pmpm.kernels.forces, pmpm.fem.nodes: the force log)."""
    out[i, j] += x


def put3(out, a, b, c, x):
    """``out[a, b, c] += x``, as :func:`put2` for 3-D arrays."""
    out[a, b, c] += x


@overload(put2, inline="always")
def _put2(out, i, j, x):
    if out.ndim == 2:
        def plain(out, i, j, x):
            out[i, j] += x
        return plain

    def exact(out, i, j, x):
        add_to(out[i, j], x)
    return exact


@overload(put3, inline="always")
def _put3(out, a, b, c, x):
    if out.ndim == 3:
        def plain(out, a, b, c, x):
            out[a, b, c] += x
        return plain

    def exact(out, a, b, c, x):
        add_to(out[a, b, c], x)
    return exact


@njit(cache=True)
def add_terms(acc, c, terms):
    """Add every term of the 1-D array ``terms`` exactly to column ``c``."""
    for i in range(terms.shape[0]):
        add(acc, c, terms[i])


@njit(cache=True)
def add_rows(acc, first, rows):
    """Add row k of ``rows`` (n, w) exactly to the columns ``first .. first + w - 1``,
    for every k."""
    for k in range(rows.shape[0]):
        for j in range(rows.shape[1]):
            add(acc, first + j, rows[k, j])
