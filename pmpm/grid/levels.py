"""The grid hierarchy: the coarse grid and the refined windows tied to it (seed 000 Sec. 3).

Every level indexes its nodes on the whole grid box refined by its ratio R: level node
(i, j, k) sits at ``origin + (i, j, k) h / R``, so the coarse grid is the level of ratio 1
and a window is the part ``R lo <= node <= R hi`` of its level (``lo``, ``hi``: the
window's coarse cell bounds, hi exclusive). The same kernels then serve every level with
``inv_h = R / h``, ``n_cells = R n_cells`` (for the box-face boundary conditions) and a
local block in the level's node indices.
"""
import numpy as np

from .grid import LocalBlock


class Window:
    """A refined window: coarse cells ``lo <= c < hi`` (int64 (3,)) refined ``ratio``
    times, optionally moving with the centroid of body ``follow`` (index, -1: fixed);
    ``residual`` is the centroid displacement not yet turned into a whole-cell move."""

    def __init__(self, lo, hi, ratio, follow=-1):
        self.lo = np.asarray(lo, dtype=np.int64)
        self.hi = np.asarray(hi, dtype=np.int64)
        self.ratio = int(ratio)
        self.follow = int(follow)
        self.residual = np.zeros(3)

    @classmethod
    def from_config(cls, window, grid, body_names):
        """From a ``pmpm.case.WindowConfig`` on the CoarseGrid ``grid``."""
        origin, h = np.asarray(grid.origin), grid.h
        lo = np.rint((np.asarray(window.min) - origin) / h).astype(np.int64)
        hi = np.rint((np.asarray(window.max) - origin) / h).astype(np.int64)
        follow = body_names.index(window.follow) if window.follow is not None else -1
        return cls(lo, hi, window.ratio, follow)

    def move(self, displacement, h, n_cells):
        """Add the followed body's centroid displacement; move by the whole coarse cells
        it amounts to (truncated towards zero, the rest carried over), staying inside the
        box. Returns True if the window moved."""
        self.residual += displacement
        wanted = np.trunc(self.residual / h).astype(np.int64)
        shift = np.clip(wanted, -self.lo, np.asarray(n_cells) - self.hi)
        self.residual -= shift * h
        # pinned at a box face: forget the motion beyond it, so that the window comes
        # back with the body at once instead of after the body has undone it
        self.residual[shift != wanted] = 0.0
        if not shift.any():
            return False
        self.lo += shift
        self.hi += shift
        return True

    def state(self):
        return {"lo": self.lo.tolist(), "hi": self.hi.tolist(),
                "residual": self.residual.tolist()}

    def restore(self, state):
        self.lo = np.asarray(state["lo"], dtype=np.int64)
        self.hi = np.asarray(state["hi"], dtype=np.int64)
        self.residual = np.asarray(state["residual"], dtype=np.float64)


class Level:
    """One grid of the hierarchy as the kernels see it: ``ratio``, ``h``, ``inv_h``,
    ``origin``, ``n_cells`` (of the whole box at this level) and the box-face
    ``boundary`` codes; ``window`` is None for the coarse grid; ``halo``: the node layers
    the shape functions reach beyond a particle's cell."""

    def __init__(self, grid, window=None, halo=0):
        self.window = window
        self.halo = halo
        self.ratio = window.ratio if window is not None else 1
        self.h = grid.h / self.ratio
        self.inv_h = self.ratio / grid.h
        self.origin = grid.origin
        self.n_cells = grid.n_cells * self.ratio
        self.boundary = grid.boundary
        self.friction = grid.friction

    @property
    def is_window(self):
        return self.window is not None

    def block(self, slabs, rank, cell_min, cell_max):
        """This rank's block of the level's nodes for particles in cells ``cell_min`` to
        ``cell_max`` (level cell indices, global over ranks), cut at the slab planes and
        widened by the shape functions' halo."""
        return LocalBlock.for_rank(slabs, rank, cell_min, cell_max, self.ratio, self.halo)

    def window_faces(self):
        """(lowest, highest) level node index of the window's faces, int64 (3,) each."""
        return self.window.lo * self.ratio, self.window.hi * self.ratio


def window_bounds(windows):
    """(lo, hi) int64 arrays (n_windows, 3) of the windows' coarse cell bounds."""
    lo = np.array([w.lo for w in windows], dtype=np.int64).reshape(-1, 3)
    hi = np.array([w.hi for w in windows], dtype=np.int64).reshape(-1, 3)
    return lo, hi
