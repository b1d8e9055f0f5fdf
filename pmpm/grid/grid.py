"""The coarse background grid and the block of its nodes that one rank holds.

The coarse grid is a box of ``n_cells`` hexahedral cells of edge ``h`` from ``origin``.
A rank holds the nodes of the cells its particles touch, clipped to its slab along the
slab axis, with the same transverse extent on every rank (the global particle bounding
box) so that a shared plane is the same array on both neighbours. Refined windows
(issue 4) add blocks of their own beside this one.
"""
import numpy as np

from ..kernels.boundary import BOUNDARY_CODES
FACES = ("x-", "x+", "y-", "y+", "z-", "z+")


class CoarseGrid:
    """Global coarse grid: ``origin`` (3,), cell edge ``h``, ``n_cells`` (3,) and a
    boundary code per box face in the order x-, x+, y-, y+, z-, z+, and the faces' Coulomb
    ``friction`` coefficients in the same order (from a mapping face -> mu; 0 if absent)."""

    def __init__(self, origin, h, n_cells, boundary, friction=None):
        self.origin = np.asarray(origin, dtype=np.float64)
        self.h = float(h)
        self.n_cells = np.asarray(n_cells, dtype=np.int64)
        self.boundary = np.array([BOUNDARY_CODES[boundary.get(f, "free")] for f in FACES],
                                 dtype=np.int64)
        friction = friction or {}
        self.friction = np.array([float(friction.get(f, 0.0)) for f in FACES])

    @classmethod
    def from_config(cls, grid):
        """From a ``pmpm.case.GridConfig``."""
        origin = np.asarray(grid.min, dtype=np.float64)
        extent = np.asarray(grid.max, dtype=np.float64) - origin
        n_cells = np.rint(extent / grid.cell).astype(np.int64)
        return cls(origin, grid.cell, n_cells, grid.boundary, grid.friction)

    @property
    def upper(self):
        return self.origin + self.n_cells * self.h

    def cells_of(self, x):
        """Integer coarse cell indices (n,3) of positions ``x`` (n,3)."""
        return np.floor((x - self.origin) / self.h).astype(np.int64)

    def inside(self, x):
        cells = self.cells_of(x)
        return np.all((cells >= 0) & (cells < self.n_cells), axis=1)

    def cell_histograms(self, x, weights=None):
        """Particle counts per coarse cell layer along each axis (three arrays), or with
        ``weights`` (n,) the sums of the points' weights (what each costs to step)."""
        cells = self.cells_of(x)
        return [np.bincount(np.clip(cells[:, a], 0, self.n_cells[a] - 1), weights,
                            minlength=int(self.n_cells[a])) for a in range(3)]


class LocalBlock:
    """The nodes ``lo <= node < lo + shape`` (global node indices) a rank holds, stored
    flat with the slab axis slowest so that a node plane normal to it is contiguous.

    Attributes
    ----------
    lo, shape : int64 (3,)
    strides : int64 (3,)   flat index of local node (i, j, k) is i*s0 + j*s1 + k*s2
    shared_planes : list of (neighbour_rank, (first, stop)): the local node planes along
        the slab axis this rank shares with a neighbour (``2 halo + 1`` planes around the
        slab plane), the same planes with the same transverse extent on both sides
    """

    def __init__(self, lo, shape, slab_axis, shared_planes):
        self.lo = np.asarray(lo, dtype=np.int64)
        self.shape = np.maximum(np.asarray(shape, dtype=np.int64), 0)
        self.slab_axis = slab_axis
        self.order = [slab_axis] + [a for a in range(3) if a != slab_axis]
        self.strides = np.zeros(3, dtype=np.int64)
        stride = 1
        for a in reversed(self.order):
            self.strides[a] = stride
            stride *= self.shape[a]
        self.n_nodes = int(np.prod(self.shape))
        self.shared_planes = shared_planes

    def as_planes(self, nodal):
        """View a flat nodal array (n_nodes, c) as (n_axis, n1, n2, c)."""
        return nodal.reshape(tuple(self.shape[self.order]) + nodal.shape[1:])

    @classmethod
    def for_rank(cls, slabs, rank, cell_min, cell_max, ratio=1, halo=0):
        """Block of ``rank`` given the global particle cell range [cell_min, cell_max],
        in the cell indices of a level refined ``ratio`` times (slab planes, on coarse
        grid lines, are then at ``ratio`` times their coarse index), widened by ``halo``
        node layers on every side for shape functions that reach beyond a particle's
        cell. A slab plane's particles on both sides then reach the ``2 halo + 1`` node
        planes around it, which both neighbours hold and sum."""
        a = slabs.axis
        first, last = (ratio * bound for bound in slabs.owned(rank))
        lo = np.array(cell_min, dtype=np.int64)
        hi = np.array(cell_max, dtype=np.int64) + 1          # last node index, inclusive
        lo[a], hi[a] = max(first, cell_min[a]), min(last, cell_max[a] + 1)
        planes = []
        shape = hi - lo + 1 + 2 * halo
        if lo[a] <= hi[a]:
            span = int(hi[a] - lo[a]) + 2 * halo
            if rank > 0 and lo[a] == first:
                planes.append((rank - 1, (0, 2 * halo + 1)))
            if rank < slabs.size - 1 and hi[a] == last:
                planes.append((rank + 1, (span - 2 * halo, span + 1)))
        else:
            # the slab holds no node of the range: no block, not the halo's planes
            # alone (a neighbour holds those nodes, complete, without sharing them)
            shape[a] = 0
        return cls(lo - halo, shape, a, planes)
