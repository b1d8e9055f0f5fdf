"""Rows in global id order, whichever rank holds them: the FEM frames (pmpm.io.elements_h5)
are laid out by node and element id, so a file is the same, row for row, on any number
of ranks and as elements move between ranks.

Every function here is collective over ``comm`` (a raw mpi4py communicator passed in;
this module never imports mpi4py). Ranks that hold no rows take part in every call.

Notes
-----
The id range ``[0, bound)`` is cut into ``comm.size`` equal blocks; block r is kept by
rank r (its *keeper*). Every rank sends each row to the keeper of its id (one all-to-all),
and a keeper sorts what it gets by id. The blocks follow each other in id order, so the
rank r's kept rows start at row ``n_0 + ... + n_(r-1)`` of the file (an exclusive scan of
the kept counts, as :mod:`pmpm.io._collective` lays out rows) and every rank writes one
contiguous block. Each rank sends and receives about its own share of the rows: no rank
gathers them all. Ids that are missing (nodes and elements gone into particles) simply
leave no row, and the rows after them close up.
"""
import numpy as np


def id_bound(comm, ids):
    """One more than the largest id on any rank (0 when no rank holds any)."""
    return max(comm.allgather(int(ids.max()) + 1 if len(ids) else 0))


def keepers(ids, bound, size):
    """The rank keeping each id: equal blocks of ``[0, bound)`` in rank order."""
    return (np.asarray(ids, np.int64) * size) // max(bound, 1)


def _split(dest, size):
    """(order, cuts): rows ``order[cuts[r]:cuts[r + 1]]`` go to rank r; ``order`` is a
    slice when the rows are already grouped by destination (ids held in ascending
    order, as FemBodies keeps them), so that no sort or copy is spent on them."""
    grouped = bool(np.all(dest[1:] >= dest[:-1]))
    order = slice(None) if grouped else np.argsort(dest, kind="stable")
    return order, np.searchsorted(dest[order], np.arange(size + 1))


def _pick(order, a, b):
    """The rows ``a:b`` of the grouping ``order`` (a slice or an index array)."""
    return slice(a, b) if isinstance(order, slice) else order[a:b]


def _sorted(ids):
    """A permutation sorting ``ids``, or a slice when they already are."""
    if np.all(ids[1:] > ids[:-1]):
        return slice(None)
    return np.argsort(ids, kind="stable")


def to_keepers(comm, ids, columns, bound):
    """Send each row of ``columns`` (dict of arrays, first axis = row, ``ids`` its global
    ids, each id held by one rank only) to the keeper of its id.

    Returns
    -------
    (ids, columns) : the rows kept here, sorted by id.
    """
    order, cuts = _split(keepers(ids, bound, comm.size), comm.size)
    packages = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        rows = _pick(order, a, b)
        packages.append((ids[rows], {k: col[rows] for k, col in columns.items()}))
    received = comm.alltoall(packages)
    kept = np.concatenate([p[0] for p in received])
    rank = _sorted(kept)
    return kept[rank], {k: np.concatenate([p[1][k] for p in received])[rank]
                        for k in columns}


def first_row(comm, n_kept):
    """The file row of this rank's first kept row: the kept counts of lower ranks."""
    total = comm.exscan(int(n_kept))
    return 0 if total is None else int(total)


def rows_of(comm, query, kept, first, bound):
    """File rows of the ids ``query`` (any rank may ask for any id that some rank keeps):
    each keeper looks them up in its ``kept`` ids (sorted; its rows start at ``first``).

    Raises
    ------
    ValueError
        On every rank alike, naming an id that no rank keeps.
    """
    order, cuts = _split(keepers(query, bound, comm.size), comm.size)
    asked = comm.alltoall([query[_pick(order, a, b)] for a, b in zip(cuts[:-1], cuts[1:])])
    answers = []
    for ids in asked:
        at = np.minimum(np.searchsorted(kept, ids), max(len(kept) - 1, 0))
        found = kept[at] == ids if len(kept) else np.zeros(len(ids), bool)
        answers.append(np.where(found, first + at, -1))
    rows = np.empty(len(query), np.int64)
    rows[order] = np.concatenate(comm.alltoall(answers))
    missing = np.concatenate(comm.allgather(query[rows < 0][:1]))
    if len(missing):
        raise ValueError(f"id {missing[0]} is kept by no rank")
    return rows
