"""History CSV (``DIR/history.csv``): energies and per-body centroid, velocity and
energies over time.

Written by rank 0 only. Header::

    step,time,dt,kinetic,internal,total,dissipated,NAME.x,NAME.y,NAME.z,NAME.vx,NAME.vy,NAME.vz,
    NAME.kinetic,NAME.internal,NAME.plastic,NAME.hourglass,...

A body's internal energy includes its elements' hourglass energy (``NAME.hourglass``,
0 for particle bodies: the work of the one-point elements' hourglass control, stored or
dissipated), so that the bodies' energies add up to the totals. ``NAME.plastic`` is the body's plastic work (the sum over
its particles and elements of mass times the specific plastic work, sigma_y d eps_p /
rho summed over the steps): the part of ``NAME.internal`` dissipated by plastic flow, not
an energy of its own (do not add it to the totals).

``total`` is kinetic + internal; ``dissipated`` is the energy contact, friction and the
grid's faces have dissipated since the start (pmpm.solver.forces: the work of their
impulses against the sliding they leave; only friction makes it nonzero; NaN with
``output.forces: false``, which turns the measure off), so that total + dissipated less
the work of gravity and the loads stays what the run was given.

Each row is flushed as it is written, so ``tail -f history.csv`` follows a running case.
Floats are written with ``repr`` (shortest exact round trip).
"""
import os

import numpy as np

from ._files import atomic_write_text, resolve

BODY_FIELDS = ("x", "y", "z", "vx", "vy", "vz", "kinetic", "internal", "plastic",
               "hourglass")
ENERGY_FIELDS = ("kinetic", "internal", "total", "dissipated")


def history_header(body_names):
    """Column names of the history CSV for ``body_names``, in order."""
    body = [f"{name}.{field}" for name in body_names for field in BODY_FIELDS]
    return ["step", "time", "dt", *ENERGY_FIELDS, *body]


def _kept_lines(path, header, restart_step):
    """Header and rows with step <= restart_step of an existing history file."""
    with open(path, encoding="utf-8") as handle:
        lines = handle.read().splitlines()
    if not lines or lines[0] != ",".join(header):
        raise ValueError(f"{path}: header differs from this run's; cannot append after a restart")
    rows = [line for line in lines[1:] if line and int(line.split(",", 1)[0]) <= restart_step]
    return [lines[0], *rows]


class HistoryWriter:
    """Appends one CSV row per call and flushes it (rank 0 only; not collective).

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file, or an output directory (then ``path/history.csv``).
    body_names : sequence of str
        Body names in the order of ``body_rows`` in :meth:`row`.
    restart_step : int, optional
        Continue the file of an interrupted run: the header is kept (and must match),
        rows with ``step > restart_step`` are dropped, being repeated by the restarted run,
        and new rows are appended. Default: start a new file with a header.
    """

    def __init__(self, path, body_names, *, restart_step=None):
        self.path = resolve(path, "history.csv")
        self.body_names = [str(name) for name in body_names]
        self.header = history_header(self.body_names)
        if restart_step is not None and os.path.exists(self.path):
            lines = _kept_lines(self.path, self.header, int(restart_step))
        else:
            lines = [",".join(self.header)]
        atomic_write_text(self.path, "\n".join(lines) + "\n")
        self._handle = open(self.path, "a", encoding="utf-8", buffering=1)

    def _body_values(self, body_rows):
        if isinstance(body_rows, dict):
            body_rows = [body_rows[name] for name in self.body_names]
        values = np.asarray(body_rows, dtype=float).reshape(-1)
        if values.size != len(BODY_FIELDS) * len(self.body_names):
            raise ValueError(f"body_rows: expected {len(self.body_names)} rows of "
                             f"{len(BODY_FIELDS)} values, got {values.size} values")
        return values

    def row(self, step, time, dt, energies, body_rows):
        """Write and flush one row.

        Parameters
        ----------
        step : int
        time, dt : float
        energies : sequence of 4 float, or dict
            Kinetic, internal, total and dissipated energy (or a dict with those keys).
        body_rows : sequence or dict
            Per body (in ``body_names`` order, or a dict keyed by name) the values
            x, y, z, vx, vy, vz (mass-weighted centroid and velocity), kinetic, internal,
            plastic, hourglass.
        """
        if isinstance(energies, dict):
            energies = [energies[key] for key in ENERGY_FIELDS]
        energies = np.asarray(energies, dtype=float).reshape(-1)
        if energies.size != len(ENERGY_FIELDS):
            raise ValueError(f"energies: expected {len(ENERGY_FIELDS)} values "
                             f"({', '.join(ENERGY_FIELDS)}), got {energies.size}")
        floats = [time, dt, *energies, *self._body_values(body_rows)]
        self._handle.write(",".join([str(int(step))] + [repr(float(v)) for v in floats]) + "\n")
        self._handle.flush()

    def close(self):
        """Close the file (safe to call twice)."""
        if not self._handle.closed:
            self._handle.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
