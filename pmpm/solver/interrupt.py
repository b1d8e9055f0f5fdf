"""SIGTERM and SIGINT (what a batch scheduler sends at the end of a job's time, or
Ctrl-C) stop a run cleanly: every rank notes the signal, the run loop finishes the step,
agrees over the ranks that a signal came, writes a checkpoint and stops with exit code 3
(``INTERRUPTED``), so that ``--restart`` continues where it stopped.

Under ``mpirun`` (Open MPI) the signal to mpirun reaches every rank as SIGTERM, and
mpirun kills the ranks ``odls_base_sigkill_timeout`` seconds later (default 1): set
``OMPI_MCA_odls_base_sigkill_timeout`` to more than a step and a checkpoint take.
"""
import signal

#: the exit status of a run stopped by a signal after writing its checkpoint
INTERRUPTED = 3
SIGNALS = (signal.SIGTERM, signal.SIGINT)

_received = 0


def _note(signum, frame):
    global _received
    if not _received:
        _received = signum


def catch_signals():
    """Note SIGTERM and SIGINT instead of dying (this rank; the main thread)."""
    for signum in SIGNALS:
        signal.signal(signum, _note)


def received():
    """The first signal this rank received (0: none)."""
    return _received


def signal_name(signum):
    return signal.Signals(signum).name


class RunInterrupted(Exception):
    """Raised on every rank at once after the checkpoint of an interrupted run."""
