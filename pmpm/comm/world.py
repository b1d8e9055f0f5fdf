"""A thin wrapper over an mpi4py communicator with the few collectives pmpm uses."""
import sys

import numpy as np


class World:
    """The ranks taking part in a run.

    Parameters
    ----------
    raw : mpi4py communicator, optional
        Defaults to ``MPI.COMM_WORLD``; MPI is initialised on first construction.
    """

    def __init__(self, raw=None):
        if raw is None:
            from mpi4py import MPI
            raw = MPI.COMM_WORLD
        self.raw = raw
        self.rank = raw.Get_rank()
        self.size = raw.Get_size()

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
            return self.raw.allreduce(value, op=op)
        send = np.ascontiguousarray(value)
        recv = np.empty_like(send)
        self.raw.Allreduce(send, recv, op=op)
        return recv

    def exscan_sum(self, value):
        """Sum of ``value`` over lower ranks (0 on rank 0)."""
        total = self.raw.exscan(value)
        return 0 if total is None else total

    def gather(self, obj):
        return self.raw.gather(obj, root=0)

    def allgather(self, obj):
        return self.raw.allgather(obj)

    def bcast(self, obj):
        return self.raw.bcast(obj, root=0)

    def barrier(self):
        self.raw.Barrier()

    def any(self, flag):
        """True on every rank when ``flag`` is true on any rank."""
        return bool(self.raw.allreduce(bool(flag), op=_mpi().LOR))

    def first_message(self, message):
        """The message of the lowest rank that has one (None if no rank has), on all ranks."""
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
