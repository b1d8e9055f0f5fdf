"""Shared-plane sums of nodal arrays and particle migration between slabs."""
import numpy as np


def sum_shared_planes(world, planes, block):
    """Add the neighbours' contributions to the nodes on shared slab planes, in place.

    Parameters
    ----------
    world : World
    planes : sequence of (neighbour_rank, (first, stop))
        The shared node planes this rank holds (see ``LocalBlock.shared_planes``); the
        neighbour holds the same planes with the same transverse extent, so one packed
        message of ``block[first:stop]`` per neighbour per phase suffices.
    block : ndarray, shape (n_axis, n1, n2, n_components)
        Local nodal values with the slab axis first, so a plane is one contiguous slice.

    Notes
    -----
    Both neighbours compute ``own + theirs`` (one addition per value), which is bitwise
    symmetric, so the two copies of a shared node stay identical.
    """
    _combine_shared_planes(world, planes, block, np.add)


def sum_shared_planes_in_layer_order(world, planes, block, kept):
    """Complete the shared slab planes of a layer-ordered scatter (see
    ``pmpm.kernels.layered``) so that they hold the one-rank sums to the bit.

    The rank below sends its planes (the sums over its layers: the one-rank fold's
    prefix), the rank above its first layers' sums ``kept`` on those planes; both then
    compute ``((prefix + kept[0]) + kept[1]) + ...``, the same additions in the same
    order as one rank, so both copies are identical and equal to one rank's.

    Parameters
    ----------
    world : World
    planes : sequence of (neighbour_rank, (first, stop)), as for ``sum_shared_planes``
    block : ndarray (n_axis, n1, n2, c), the nodal array with the slab axis first, or
        a dict of span -> view (the contact slots of the shared planes)
    kept : ndarray (stop - first,) + the lower span's shape: the sums of this rank's
        first ``stop - first`` cell layers on the planes it shares with the rank below
        (as many layers as the span has planes)
    """
    if not planes:
        return
    MPI = _mpi()
    requests, received = [], []
    for neighbour, span in planes:
        below = neighbour < world.rank
        own = _planes(block, span)
        outgoing = kept if below else np.ascontiguousarray(own)
        incoming = np.empty_like(own) if below else \
            np.empty((span[1] - span[0],) + own.shape)
        requests.append(world.raw.Irecv(incoming, source=neighbour, tag=72))
        requests.append(world.raw.Isend(outgoing, dest=neighbour, tag=72))
        world.traffic.note("neighbour", outgoing.nbytes)
        received.append((below, own, incoming, outgoing))
    MPI.Request.Waitall(requests)
    for below, own, incoming, outgoing in received:
        own[...] = fold_layers(incoming, kept) if below else fold_layers(outgoing, incoming)


def fold_layers(prefix, layers):
    """``((prefix + layers[0]) + layers[1]) + ...``: the lower rank's sums continued with
    the upper rank's layer sums, in layer order (a new array)."""
    total = prefix.copy()
    for layer in layers:
        total += layer
    return total


def continue_shared_planes(world, planes, block, add_lower):
    """Complete sums whose terms on the shared slab planes are added in rank order: the
    rank below has added its terms to the planes it shares with the rank above (the
    one-rank fold's prefix) and sends them up; this rank takes them as its planes shared
    with the rank below, ``add_lower()`` continues the fold there with its own terms,
    and it sends the result down, where it replaces the copy of the rank below. Every
    rank has added its terms to its other planes before the call (the prefix it sends
    up), so two rounds of one message per neighbour suffice.

    Parameters
    ----------
    world : World
    planes : sequence of (neighbour_rank, (first, stop)), as for ``sum_shared_planes``
    block : ndarray (n_axis, n1, n2, c), the nodal array with the slab axis first
    add_lower : callable   adds this rank's terms to its planes shared with the rank below
    """
    below = [(n, span) for n, span in planes if n < world.rank]
    above = [(n, span) for n, span in planes if n > world.rank]
    _pass_planes(world, block, above, below, 73)        # the prefixes go up
    add_lower()
    _pass_planes(world, block, below, above, 74)        # the complete sums come down


def take_marked_planes(world, planes, block, marked):
    """Complete terms on the shared slab planes that not every rank holding a node could
    add: where the neighbour added its term to a node (``marked``) and this rank did
    not, this rank takes the neighbour's copy; where both did, the copies are alike.
    One message of the planes and their marks per neighbour.

    Parameters
    ----------
    world : World
    planes : sequence of (neighbour_rank, (first, stop)), as for ``sum_shared_planes``
    block : ndarray (n_axis, n1, n2, c), the nodal array with the slab axis first
    marked : ndarray (n_axis, n1, n2), nonzero where this rank added the term
    """
    if not planes:
        return
    packed = {span: np.concatenate([block[span[0]:span[1]],
                                    (marked[span[0]:span[1]] != 0)[..., None]], axis=-1)
              for _, span in planes}
    _combine_shared_planes(world, planes, packed, _take_marked)
    for _, span in planes:
        block[span[0]:span[1]] = packed[span][..., :-1]


def _take_marked(own, incoming, out):
    """``out`` = ``incoming`` at the nodes the neighbour marked (last column) and this
    rank did not; ``own`` elsewhere."""
    take = (incoming[..., -1] > 0) & (own[..., -1] == 0)
    out[take] = incoming[take]


def _pass_planes(world, block, senders, receivers, tag):
    """Send ``block``'s planes of the spans ``senders`` to their neighbours and replace
    those of ``receivers`` by the neighbours' copies."""
    if not senders and not receivers:
        return
    MPI = _mpi()
    requests, received, sent = [], [], []
    for neighbour, span in receivers:
        incoming = np.empty_like(block[span[0]:span[1]])
        requests.append(world.raw.Irecv(incoming, source=neighbour, tag=tag))
        received.append((span, incoming))
    for neighbour, span in senders:
        outgoing = np.ascontiguousarray(block[span[0]:span[1]])
        sent.append(outgoing)
        requests.append(world.raw.Isend(outgoing, dest=neighbour, tag=tag))
        world.traffic.note("neighbour", outgoing.nbytes)
    MPI.Request.Waitall(requests)
    for span, incoming in received:
        block[span[0]:span[1]] = incoming


def or_shared_planes(world, planes, block):
    """Like ``sum_shared_planes`` for integer bit masks: OR in the neighbours' bits."""
    _combine_shared_planes(world, planes, block, np.bitwise_or)


def max_shared_planes(world, planes, block):
    """Like ``sum_shared_planes``, keeping the larger of the two copies (symmetric, so the
    two copies stay identical)."""
    _combine_shared_planes(world, planes, block, np.maximum)


def _combine_shared_planes(world, planes, block, combine):
    """``block[first:stop] = combine(block[first:stop], neighbour's copy)`` for every
    shared span of planes; ``block`` may also be a dict of span -> view."""
    if not planes:
        return
    MPI = _mpi()
    requests, received = [], []
    for neighbour, span in planes:
        outgoing = np.ascontiguousarray(_planes(block, span))
        incoming = np.empty_like(outgoing)
        requests.append(world.raw.Irecv(incoming, source=neighbour, tag=71))
        requests.append(world.raw.Isend(outgoing, dest=neighbour, tag=71))
        world.traffic.note("neighbour", outgoing.nbytes)
        received.append((span, incoming, outgoing))
    MPI.Request.Waitall(requests)
    for span, incoming, _ in received:
        view = _planes(block, span)
        combine(view, incoming, out=view)


def _planes(block, span):
    return block[span] if isinstance(block, dict) else block[span[0]:span[1]]


def migrate_store(world, destination, store, check=True):
    """Send every row of ``store`` (a ColumnStore) to the rank ``destination[p]``, in place.

    Only the rows that leave this rank are packed, into one buffer of whole rows; one
    Alltoall of counts and one Alltoallv of rows carry them, and the staying rows are
    kept with ``store.take``. The new order is: rows by source rank, stable within a
    source, this rank's staying rows as its own block (the order the answers depend on:
    scatter sums follow it).

    Parameters
    ----------
    world : World
    destination : int array (n,), every entry a rank (no -1)
    store : ColumnStore
    check : bool
        First agree (one reduction) whether any row moves at all; pass False when the
        caller already knows some does.
    """
    destination = np.asarray(destination, np.int64)
    if check and world.sum(int(np.count_nonzero(destination != world.rank))) == 0:
        return
    leaving = np.flatnonzero(destination != world.rank)
    leaving = leaving[np.argsort(destination[leaving], kind="stable")]
    send_counts = np.bincount(destination[leaving], minlength=world.size).astype(np.int64)
    recv_counts = np.empty_like(send_counts)
    world.raw.Alltoall(send_counts, recv_counts)
    rows = store.rows(leaving)
    world.traffic.note("alltoall", rows.nbytes + send_counts.nbytes,
                       np.count_nonzero(send_counts))
    received = _alltoallv_rows(world, rows, send_counts, recv_counts)
    if len(leaving) == 0 and len(received) == 0:
        return          # nothing left or came: the columns stay as they are (no copy)
    lower = int(recv_counts[:world.rank].sum())
    store.take(destination == world.rank, before=received[:lower], after=received[lower:])


def _alltoallv_rows(world, rows, send_counts, recv_counts):
    """Alltoallv of a structured array, counted in whole rows (an MPI type of one row,
    so byte counts never overflow an int)."""
    recv = np.empty(int(recv_counts.sum()), rows.dtype)
    row = _mpi().BYTE.Create_contiguous(rows.dtype.itemsize).Commit()
    try:
        world.raw.Alltoallv([rows.view(np.uint8), (send_counts, _offsets(send_counts)), row],
                            [recv.view(np.uint8), (recv_counts, _offsets(recv_counts)), row])
    finally:
        row.Free()
    return recv


def _offsets(counts):
    return np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)


def _mpi():
    from mpi4py import MPI
    return MPI
