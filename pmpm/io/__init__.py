"""Output layer: parallel HDF5 particle frames, XDMF, history CSV, summary JSON, checkpoints.

Every collective function takes the raw mpi4py communicator as ``comm`` and uses only its
methods, so this package never imports mpi4py itself (h5py's ``mpio`` driver needs the raw
communicator). The names below are imported lazily: ``import pmpm.io`` loads nothing heavy.

==========================  ===============================================================
``ParticleWriter``          ``DIR/particles.h5`` frames, written collectively, plus the XDMF
``write_xdmf``              ``DIR/particles.xdmf`` for ParaView (rank 0)
``HistoryWriter``           ``DIR/history.csv`` (rank 0)
``write_summary``           ``DIR/summary.json`` (rank 0), keys checked against the run contract
``save_checkpoint``         ``DIR/checkpoint_NNNNNN.h5``, collective, atomic, rotated
``latest_checkpoint``       newest complete checkpoint in a directory, or None
``load_checkpoint``         scalars and an equal contiguous share of the rows on every rank
``read_checkpoint_case``    the case a checkpoint's run was started with (rank 0)
==========================  ===============================================================
"""
from importlib import import_module

_EXPORTS = {
    "ParticleWriter": "particles_h5",
    "write_xdmf": "xdmf",
    "HistoryWriter": "history",
    "write_summary": "summary",
    "validate_summary": "summary",
    "save_checkpoint": "checkpoint",
    "latest_checkpoint": "checkpoint",
    "load_checkpoint": "checkpoint",
    "load_group": "checkpoint",
    "read_checkpoint_case": "checkpoint",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'pmpm.io' has no attribute {name!r}")
    return getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
