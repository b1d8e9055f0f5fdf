"""Exact sums whose bits do not depend on the rank count or the order of the terms.

An accumulator column holds the exact sum of the terms added so far in fixed point: a
double is an integer (53 bits) times a power of two from 2**-1074 to 2**971, so every
double is a whole multiple of 2**-1074 and their sum is an integer multiple too, kept
in :data:`BINS` int64 bins of 32 binary places each (Neal's "small superaccumulator",
arXiv:1505.05571). A term adds its significand, cut at a bin boundary, into two
bins; every :data:`CARRY_EVERY` terms the bins carry into the next, so none overflows.
The ranks' bins add as integers, exactly and in any order (one SUM reduction,
:func:`pmpm.solver.observe.exact_totals`), and the total is rounded to a double once.
So an output column summed this way is the same on 1 and N ranks as long as each term
is (a particle's ``m x``, an FE node's, a contact node's impulse), with no canonical
order to keep. Non-finite terms are counted apart (+inf, -inf, NaN) and give the
column's inf or NaN as a plain sum would.

An accumulator is an int64 array (columns, :data:`WIDTH`): per column the bins, the
terms since the last carry, and the counts of +inf, -inf and NaN terms. A term costs
about a dozen integer operations.
"""
import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic, overload

#: bins of 32 binary places: the lowest significand bit of a double sits at place 0
#: (2**-1074) to 2045, its highest at most 2098; two more bins take the carries
BINS = 67
#: where the column's count of terms since the last carry, and of +inf, -inf and NaN
#: terms, are kept
SINCE, POS_INF, NEG_INF, NAN = BINS, BINS + 1, BINS + 2, BINS + 3
WIDTH = BINS + 4
#: a term adds less than 2**53 to a bin: 1024 of them stay below 2**63
CARRY_EVERY = 1024
LOW = (1 << 32) - 1


def zeros(shape):
    """An empty accumulator of ``shape`` columns (an int, or a tuple: then one column
    per entry, the bins last)."""
    shape = (int(shape),) if np.isscalar(shape) else tuple(shape)
    return np.zeros(shape + (WIDTH,), np.int64)


@njit(cache=True, inline="always")
def add(acc, c, x):
    """Add the term ``x`` exactly to column ``c`` of ``acc``."""
    add_to(acc[c], x)


@intrinsic
def float_bits(typingctx, x):
    """The IEEE 754 bits of the double ``x`` as an int64 (a bit cast, no call)."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))
    return types.int64(types.float64), codegen


@njit(cache=True, inline="always")
def add_to(column, x):
    """Add the term ``x`` exactly to one accumulator ``column`` (WIDTH,): its 53-bit
    significand, from its lowest bit's place (its biased exponent less one; 0 for the
    subnormals), into the bin of that place and the next."""
    bits = float_bits(x)
    biased = (bits >> 52) & 0x7FF
    significand = bits & 0xFFFFFFFFFFFFF
    if biased == 0x7FF:                                # inf or NaN
        column[NAN if significand else (NEG_INF if bits < 0 else POS_INF)] += 1
        return
    if biased == 0:
        if significand == 0:                           # +-0
            return
        place = 0
    else:
        significand |= np.int64(1) << 52
        place = biased - 1
    b, shift = place >> 5, place & 31
    low = (significand & ((np.int64(1) << (32 - shift)) - 1)) << shift
    high = significand >> (32 - shift)
    if bits < 0:
        column[b] -= low
        column[b + 1] -= high
    else:
        column[b] += low
        column[b + 1] += high
    column[SINCE] += 1
    if column[SINCE] >= CARRY_EVERY:
        carry(column)


@njit(cache=True)
def carry(column):
    """Carry each bin's excess over 32 places into the next (the top bin keeps the
    sign): the bins then hold the same sum, each below 2**32 in size."""
    for b in range(BINS - 1):
        over = column[b] >> 32                         # floor: the low part stays >= 0
        column[b] -= over << 32
        column[b + 1] += over
    column[SINCE] = 0


@njit(cache=True)
def carry_all(acc):
    """:func:`carry` on every column of ``acc`` (columns, WIDTH), before the ranks'
    bins are added."""
    for c in range(acc.shape[0]):
        carry(acc[c])


def rounded(column):
    """The double nearest the exact sum in ``column`` (a carried column, or the sum of
    carried columns over the ranks), ties to even; inf or NaN as the non-finite terms
    give."""
    if column[NAN] or (column[POS_INF] and column[NEG_INF]):
        return math.nan
    if column[POS_INF] or column[NEG_INF]:
        return math.inf if column[POS_INF] else -math.inf
    total = 0
    for b in range(BINS - 1, -1, -1):
        total = (total << 32) + int(column[b])
    try:
        return total / (1 << 1074)                     # Python rounds int / int exactly
    except OverflowError:
        return math.inf if total > 0 else -math.inf


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


@njit(cache=True)
def add_rows_in_order(total, nodes, parts, order):
    """``total[nodes[j]] += parts[order[j]]`` for j = 0, 1, ... in turn: plain double
    sums in a fixed order (the element-order sums over shared FE nodes,
    pmpm.comm.shared_nodes.ElementOrderSums), as ``np.add.at`` adds, at a tenth of its
    cost."""
    for j in range(nodes.shape[0]):
        n, r = nodes[j], order[j]
        for i in range(total.shape[1]):
            total[n, i] += parts[r, i]


def put2(out, i, j, x):
    """``out[i, j] += x`` for a float array (2-D), exactly for an accumulator of that
    shape (3-D, the bins last): a kernel that takes either sums plainly or exactly
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
