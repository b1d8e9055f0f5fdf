"""Force histories (``DIR/forces.csv``, rank 0): one row per history row, ``step,time,``
then the columns of pmpm.solver.forces.ForceLog (per body pair ``A/B.fx, fy, fz,
normal, tangential``: the force on A from B; per constrained grid face ``x-.fx, ...``;
per FEM body with constrained nodes ``NAME.support.fx, ...``), each the mean force over
the interval since the previous row, flushed as written. A restart keeps the rows up to
its checkpoint's step and appends (as history.csv)."""
import os

from ._files import atomic_write_text
from .history import _kept_lines


class ForcesWriter:
    def __init__(self, out_dir, columns, *, restart_step=None):
        self.path = os.path.join(out_dir, "forces.csv")
        self.header = ["step", "time", *columns]
        if restart_step is not None and os.path.exists(self.path):
            lines = _kept_lines(self.path, self.header, int(restart_step))
        else:
            lines = [",".join(self.header)]
        atomic_write_text(self.path, "\n".join(lines) + "\n")
        self.handle = open(self.path, "a", encoding="utf-8")

    def row(self, step, time, values):
        self.handle.write(",".join([str(int(step)), repr(float(time))]
                                   + [repr(float(v)) for v in values]) + "\n")
        self.handle.flush()

    def close(self):
        if not self.handle.closed:
            self.handle.close()
