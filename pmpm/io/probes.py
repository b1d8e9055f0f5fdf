"""Probe histories (``DIR/probe_NAME.csv``, rank 0): one row per history row of the run,
``step,time,`` then pmpm.solver.probes.COLUMNS (position, velocity, stress xx yy zz xy yz
zx, eps_p, pressure, von Mises), flushed as written. A restart keeps the rows up to its
checkpoint's step and appends (as history.csv)."""
import os

from ._files import atomic_write_text
from .history import _kept_lines


class ProbeWriter:
    def __init__(self, out_dir, names, columns, *, restart_step=None):
        self.header = ["step", "time", *columns]
        self.handles = {}
        for name in names:
            path = os.path.join(out_dir, f"probe_{name}.csv")
            if restart_step is not None and os.path.exists(path):
                lines = _kept_lines(path, self.header, int(restart_step))
            else:
                lines = [",".join(self.header)]
            atomic_write_text(path, "\n".join(lines) + "\n")
            self.handles[name] = open(path, "a", encoding="utf-8")

    def rows(self, step, time, values):
        """One row per probe (``values``: probes x columns, in ``names`` order)."""
        for handle, row in zip(self.handles.values(), values):
            handle.write(",".join([str(int(step)), repr(float(time))]
                                  + [repr(float(v)) for v in row]) + "\n")
            handle.flush()

    def close(self):
        for handle in self.handles.values():
            if not handle.closed:
                handle.close()
