"""Sparse exchanges of packed arrays: each rank sends one message, of one contiguous
buffer, to each rank it has something for, and learns who sends to it without an
all-to-all (the NBX algorithm of Hoefler, Siebert and Lumsdaine, "Scalable communication
protocols for dynamic sparse data exchange", PPoPP 2010).

Every step the FEM contacts (their segment halo and node sums: pmpm.solver.contact_sums,
surface_contact, node_contact) and the grid coupling's lent nodes (pmpm.solver.fem_grid)
send a few arrays to a few ranks, and element migration (pmpm.solver.fem_bodies) sends
columns to the ranks elements move to. Before issue 24 these were all-to-alls of pickled
objects: P messages per call on P ranks, empty ones included, and a pickle of every
array. Here a call costs one message per rank that gets something plus one non-blocking
barrier.

Where both sides know already who sends to whom (the answers to an exchange's
questions, or a choice every rank makes from the same gathered boxes),
:func:`exchange_known` sends the packages without the barrier.

A package is a tuple (or a dict with fixed keys) of numpy arrays with a first (row) axis.
Its buffer is a header of int64 words (the header's length in words, the number of
arrays, then per array its dtype code, number of axes and shape) and the arrays' bytes, each started on a 16-byte
boundary, so the receiver reads every array as a view of the buffer without a copy.
"""
import numpy as np

#: the first tag of the exchanges; consecutive calls use TAG_BASE + count % TAG_CYCLE.
#: A call ends only when every rank has sent and received all its messages (the
#: barrier), so a rank that is already in the next call cannot meet a message of the
#: one before it: two tags would do; a few more cost nothing.
TAG_BASE, TAG_CYCLE = 20000, 4
ALIGN = 16
#: the tag of :func:`exchange_known`: its messages go to known ranks, each received by
#: source in the order sent (MPI keeps the order of messages between two ranks on one
#: tag), so one tag serves every call
KNOWN_TAG = TAG_BASE + TAG_CYCLE


def exchange_arrays(world, packages):
    """Send ``packages[r]`` to rank r; return what every rank sent here, by source rank
    (collective: every rank calls it, the same number of times).

    Parameters
    ----------
    world : World
    packages : list of world.size packages
        Each a tuple or dict of arrays, or None. A package whose arrays all have no
        element (or None) is not sent. ``packages[world.rank]``, this rank's own share,
        is returned as it is (never sent); it must not be None: it gives the fields,
        dtypes and trailing shapes of the zero-row packages returned for the ranks that
        send nothing here, and a dict's key order (other ranks' dicts must have the same
        keys).

    Returns
    -------
    list of world.size packages, ordered by source rank as an all-to-all would give them,
    the received arrays views of their message's buffer (their dtypes and shapes as
    sent). On one rank: ``[packages[0]]``, without any MPI call.
    """
    if len(packages) != world.size:
        raise ValueError(f"exchange_arrays: {len(packages)} packages for {world.size} ranks")
    own = packages[world.rank]
    if own is None:
        raise ValueError("exchange_arrays: this rank's own package is None; it is the "
                         "template of the packages not sent")
    if world.size == 1:
        return [own]
    keys = list(own) if isinstance(own, dict) else None
    outgoing = {r: pack(fields(p, keys)) for r, p in enumerate(packages)
                if r != world.rank and p is not None and not is_empty(fields(p, keys))}
    received = nbx(world, outgoing)
    empty = zero_rows(fields(own, keys))
    out = []
    for r in range(world.size):
        arrays = unpack(received[r]) if r in received else empty
        out.append(own if r == world.rank else
                   dict(zip(keys, arrays)) if keys is not None else arrays)
    return out


def senders(packages, own_rank):
    """The ranks whose package in a list returned by :func:`exchange_arrays` was sent
    (has an element), this rank excluded: every rank knows after the exchange who sent
    to it, and whom it sent to (:func:`sent_to`), without another message."""
    return [r for r, p in enumerate(packages) if r != own_rank and not is_empty(
        fields(p, list(p) if isinstance(p, dict) else None))]


def sent_to(packages, own_rank):
    """The ranks :func:`exchange_arrays` sends ``packages`` to (those not empty)."""
    return [r for r, p in enumerate(packages) if r != own_rank and p is not None
            and not is_empty(fields(p, list(p) if isinstance(p, dict) else None))]


def exchange_known(world, packages, destinations, sources):
    """An exchange whose partners both sides know already, without NBX's barrier:
    send ``packages[r]`` to each rank r of ``destinations`` (even a package without
    rows: its receiver waits for it) and receive one package from each rank of
    ``sources``. Used where an exchange before it told every rank who sends to it (the
    answers to questions, pmpm.solver.contact_sums: the askers and the asked), or where
    every rank decides from the same gathered data whether s sends to r (node contact's
    halo, from the allgathered boxes). Nothing at all is sent where a rank has no
    partner. The calls must come in the same order on every rank (as for every
    collective); the messages of two ranks keep their order (MPI's rule on one tag), so
    one tag serves every call.

    Parameters
    ----------
    packages : list of world.size packages (as for :func:`exchange_arrays`); those of
        ranks not in ``destinations`` are not sent, ``packages[world.rank]`` is returned
        as is and is the template of the zero-row packages of the ranks not in
        ``sources``.
    destinations, sources : lists of ranks, this rank excluded

    Returns
    -------
    list of world.size packages, by source rank, as :func:`exchange_arrays` returns.
    """
    own = packages[world.rank]
    if world.size == 1:
        return [own]
    from mpi4py import MPI
    keys = list(own) if isinstance(own, dict) else None
    comm = world.raw
    buffers = {r: pack(fields(packages[r], keys)) for r in destinations}
    sends = [comm.Isend([buf, MPI.BYTE], dest=r, tag=KNOWN_TAG)
             for r, buf in buffers.items()]
    world.traffic.note("neighbour", sum(b.nbytes for b in buffers.values()), len(buffers))
    received, status = {}, MPI.Status()
    for r in sources:
        comm.Probe(source=r, tag=KNOWN_TAG, status=status)
        buf = np.empty(status.Get_count(MPI.BYTE), np.uint8)
        comm.Recv([buf, MPI.BYTE], source=r, tag=KNOWN_TAG)
        received[r] = unpack(buf)
    MPI.Request.Waitall(sends)
    empty = zero_rows(fields(own, keys))
    out = []
    for r in range(world.size):
        arrays = received.get(r, empty)
        out.append(own if r == world.rank else
                   dict(zip(keys, arrays)) if keys is not None else arrays)
    return out


def nbx(world, outgoing):
    """{source: uint8 buffer} of the messages sent here, given {destination: buffer}:
    synchronous sends, then receive whatever arrives until a non-blocking barrier,
    entered once this rank's sends are all matched, completes on every rank (then
    every message of every rank has been received)."""
    from mpi4py import MPI
    comm = world.raw
    tag = TAG_BASE + world.exchanges % TAG_CYCLE
    world.exchanges += 1
    sends = [comm.Issend([buf, MPI.BYTE], dest=r, tag=tag) for r, buf in outgoing.items()]
    world.traffic.note("neighbour", sum(buf.nbytes for buf in outgoing.values()),
                       len(outgoing))
    world.traffic.note("collective", 0)         # the barrier
    received, barrier, status = {}, None, MPI.Status()
    while True:
        if comm.Iprobe(source=MPI.ANY_SOURCE, tag=tag, status=status):
            source = status.Get_source()
            buf = np.empty(status.Get_count(MPI.BYTE), np.uint8)
            comm.Recv([buf, MPI.BYTE], source=source, tag=tag)
            received[source] = buf
        elif barrier is None:
            if MPI.Request.Testall(sends):
                barrier = comm.Ibarrier()
        elif barrier.Test():
            return received


def fields(package, keys):
    """The package's arrays in order (a dict's in ``keys`` order)."""
    if keys is None:
        return tuple(np.asarray(a) for a in package)
    if set(package) != set(keys):
        raise ValueError(f"exchange_arrays: a package has the keys {sorted(map(str, package))}"
                         f", this rank's own {sorted(map(str, keys))}")
    return tuple(np.asarray(package[k]) for k in keys)


def is_empty(arrays):
    return all(a.size == 0 for a in arrays)


def zero_rows(arrays):
    """Arrays of no row with the dtypes and trailing shapes of ``arrays``."""
    return tuple(np.empty((0,) + a.shape[1:], a.dtype) for a in arrays)


def _padded(n):
    return -(-n // ALIGN) * ALIGN


def pack(arrays):
    """One uint8 buffer of ``arrays``: the header (see the module docstring), then each
    array's bytes at a 16-byte boundary."""
    header = [0, len(arrays)]
    for a in arrays:
        if a.dtype.kind in "OVSUM":
            raise TypeError(f"exchange_arrays: cannot send arrays of dtype {a.dtype}")
        header += [ord(a.dtype.char), a.ndim, *a.shape]
    header[0] = len(header)
    head = np.array(header, np.int64)
    starts, at = [], _padded(head.nbytes)
    for a in arrays:
        starts.append(at)
        at = _padded(at + a.nbytes)
    buf = np.empty(at, np.uint8)
    buf[:head.nbytes] = head.view(np.uint8)
    for a, start in zip(arrays, starts):
        native = a if a.dtype.isnative else a.astype(a.dtype.newbyteorder("="))
        buf[start:start + a.nbytes] = np.ascontiguousarray(native).reshape(-1).view(np.uint8)
    return buf


def unpack(buf):
    """The arrays of a buffer made by :func:`pack`, as views of it."""
    n_words = int(buf[:8].view(np.int64)[0])
    words = buf[:8 * n_words].view(np.int64)
    at, arrays, word = _padded(8 * n_words), [], 2
    for _ in range(int(words[1])):
        dtype, ndim = np.dtype(chr(int(words[word]))), int(words[word + 1])
        shape = tuple(int(d) for d in words[word + 2:word + 2 + ndim])
        word += 2 + ndim
        nbytes = dtype.itemsize * int(np.prod(shape, dtype=np.int64))
        arrays.append(buf[at:at + nbytes].view(dtype).reshape(shape))
        at = _padded(at + nbytes)
    return tuple(arrays)
