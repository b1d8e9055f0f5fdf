"""Arrays reused from step to step."""
import numpy as np


class Workspace:
    """Nodal arrays reused from step to step (grown, never shrunk)."""

    def __init__(self):
        self._buffers = {}

    def zeros(self, name, rows, width):
        view = self.empty(name, rows, width)
        view.fill(0.0)
        return view

    def empty(self, name, rows, width, dtype=np.float64):
        """Uninitialised rows, for arrays a kernel overwrites entirely."""
        buf = self._buffers.get(name)
        if buf is None or buf.shape[0] < rows:
            buf = np.empty((max(rows, 1024) * 5 // 4, width), dtype=dtype)
            self._buffers[name] = buf
        return buf[:rows]
