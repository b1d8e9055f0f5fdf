"""Open MPI's start-up, made quick where the ranks of a run share one machine.

MPI_Init under Open MPI 4.1 (this machine: Debian's build with libfabric, PSM, PSM2 and
UCX) spends 0.25-0.4 s of wall time, with some 0.05 s of CPU, probing for network
hardware that one machine's ranks never use (a process started without ``mpirun``, a
singleton, also forks a helper daemon). Choosing the ``ob1`` messaging layer (what Open
MPI picks on one machine without UCX anyway, over shared memory) skips the probes:
0.06-0.15 s on 2 ranks, about 0.2 s for a singleton (docs/performance-notes.md,
"Start-up"). Nothing a run computes changes: the layer carries the bytes, the
reductions' order is the collective module's.

The choices are made only where they are safe and only when the user made none: a
variable the environment already sets (any ``OMPI_MCA_pml``, ``OMPI_MCA_btl`` or
``OMPI_MCA_mtl``) leaves every choice to the user, and a job whose ranks span machines
(Open MPI's local size less than its size) or that another launcher started (Slurm's
``srun``, MPICH's Hydra) is left alone; for MPICH the variables mean nothing.
"""
import contextlib
import os
import sys

#: the variables whose presence says the user chose Open MPI's transports
USER_CHOICES = ("OMPI_MCA_pml", "OMPI_MCA_btl", "OMPI_MCA_mtl")

#: the variables other launchers than Open MPI's set on each rank
OTHER_LAUNCHERS = ("PMI_RANK", "SLURM_PROCID", "PMIX_RANK")

#: a job of one or more ranks on one machine, launched by Open MPI's mpirun
ONE_MACHINE = {"OMPI_MCA_pml": "ob1"}

#: one process without a launcher: nothing to talk to but itself. Its helper daemon
#: stays (``ess_singleton_isolated`` would save 0.15 s more, but every isolated
#: singleton on a machine shares one session folder, which the first to finish
#: deletes under the others: their MPI-IO then falls back to lock files beside the
#: output, with an error line per file opened)
SINGLETON = {"OMPI_MCA_pml": "ob1", "OMPI_MCA_btl": "self"}


def quick_start_settings(environ):
    """The Open MPI variables that would make MPI_Init quick for the process whose
    environment is ``environ``, or {} where the choice is the user's or unsafe."""
    if any(name in environ for name in USER_CHOICES):
        return {}
    size = environ.get("OMPI_COMM_WORLD_SIZE")
    if size is not None:
        local = environ.get("OMPI_COMM_WORLD_LOCAL_SIZE")
        return dict(ONE_MACHINE) if local == size else {}
    if any(name in environ for name in OTHER_LAUNCHERS):
        return {}
    return dict(SINGLETON)


@contextlib.contextmanager
def quick_mpi_start(environ=None):
    """Around MPI's initialisation: :func:`quick_start_settings` in this process's
    environment, where Open MPI reads them, and the environment as it was after, so that
    the processes this one may start (a test's ``mpirun``) do not inherit a singleton's
    choices. Does nothing once MPI is initialised."""
    environ = os.environ if environ is None else environ
    settings = {} if "mpi4py.MPI" in sys.modules else quick_start_settings(environ)
    environ.update(settings)
    try:
        yield settings
    finally:
        for name in settings:
            environ.pop(name, None)
