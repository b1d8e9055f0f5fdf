"""A thin wrapper over an mpi4py communicator with the few collectives pmpm uses, and
the count of what this rank sends (:class:`Traffic`), for the scaling model
(scripts/scaling.py) and summary.json."""
import pickle
import sys

import numpy as np


class Traffic:
    """What this rank has sent since :meth:`reset`: point-to-point messages to
    neighbours (shared slab planes, shared FE nodes, the sparse exchanges of
    pmpm.comm.sparse) and their bytes, collectives
    (reductions, gathers, broadcasts) and their bytes, and all-to-all exchanges
    (particle migration) with the messages and bytes that went to other ranks."""

    KINDS = ("neighbour", "collective", "alltoall")

    def __init__(self):
        self.reset()

    def reset(self):
        self.messages = dict.fromkeys(self.KINDS, 0)
        self.bytes = dict.fromkeys(self.KINDS, 0)

    def note(self, kind, nbytes, messages=1):
        self.messages[kind] += int(messages)
        self.bytes[kind] += int(nbytes)


def payload_bytes(obj):
    """About the bytes of ``obj`` on the wire, without pickling the arrays again: their
    buffers, summed through tuples, lists and dicts; 8 a number; the pickle of anything
    else (small: strings, tuples of numbers)."""
    if isinstance(obj, np.ndarray):
        return obj.nbytes
    if obj is None:
        return 0
    if isinstance(obj, (int, float, bool, np.generic)):
        return 8
    if isinstance(obj, (list, tuple)):
        return sum(payload_bytes(item) for item in obj)
    if isinstance(obj, dict):
        return sum(payload_bytes(k) + payload_bytes(v) for k, v in obj.items())
    try:
        return len(pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))
    except Exception:       # an object that does not pickle is not sent either
        return 0


class World:
    """The ranks taking part in a run.

    Parameters
    ----------
    raw : mpi4py communicator, optional
        Defaults to ``MPI.COMM_WORLD``; MPI is initialised on first construction,
        quickly where the ranks share a machine (pmpm.comm.launch).
    """

    def __init__(self, raw=None):
        if raw is None:
            from .launch import quick_mpi_start
            with quick_mpi_start():
                from mpi4py import MPI
            raw = MPI.COMM_WORLD
        self.raw = raw
        self.rank = raw.Get_rank()
        self.size = raw.Get_size()
        self.traffic = Traffic()
        self.exchanges = 0      # sparse exchanges so far: their tags (pmpm.comm.sparse)

    @property
    def is_root(self):
        return self.rank == 0

    def sum(self, value):
        return self._reduce(value, "SUM")

    def max(self, value):
        return self._reduce(value, "MAX")

    def min(self, value):
        return self._reduce(value, "MIN")

    def _reduce(self, value, op_name):
        from mpi4py import MPI
        op = getattr(MPI, op_name)
        if np.isscalar(value):
            self.traffic.note("collective", 8)
            return self.raw.allreduce(value, op=op)
        send = np.ascontiguousarray(value)
        self.traffic.note("collective", send.nbytes)
        recv = np.empty_like(send)
        self.raw.Allreduce(send, recv, op=op)
        return recv

    def exscan_sum(self, value):
        """Sum of ``value`` over lower ranks (0 on rank 0)."""
        self.traffic.note("collective", 8)
        total = self.raw.exscan(value)
        return 0 if total is None else total

    def gather(self, obj):
        self.traffic.note("collective", payload_bytes(obj))
        return self.raw.gather(obj, root=0)

    def allgather(self, obj):
        self.traffic.note("collective", payload_bytes(obj))
        return self.raw.allgather(obj)

    def bcast(self, obj):
        self.traffic.note("collective", payload_bytes(obj) if self.is_root else 0)
        return self.raw.bcast(obj, root=0)

    def barrier(self):
        self.raw.Barrier()

    def any(self, flag):
        """True on every rank when ``flag`` is true on any rank."""
        self.traffic.note("collective", 1)
        return bool(self.raw.allreduce(bool(flag), op=_mpi().LOR))

    def first_message(self, message):
        """The message of the lowest rank that has one (None if no rank has), on all ranks."""
        self.traffic.note("collective", payload_bytes(message))
        messages = self.raw.allgather(message)
        return next((m for m in messages if m), None)

    def abort(self, message, code=1):
        """Print ``message`` and stop every rank (for faults only one rank sees)."""
        sys.stderr.write(f"pmpm: rank {self.rank}: {message}\n")
        sys.stderr.flush()
        self.raw.Abort(code)


def _mpi():
    from mpi4py import MPI
    return MPI


_WORLD = None


def world():
    """The process-wide :class:`World` over ``COMM_WORLD``, created on first call."""
    global _WORLD
    if _WORLD is None:
        _WORLD = World()
    return _WORLD
