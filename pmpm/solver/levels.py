"""The grids of one step on one rank: the coarse grid and the refined windows, each with
its node block and nodal arrays (seed 000 Sec. 3.1)."""
import numpy as np

from ..comm import sum_shared_planes
from ..comm.exchange import sum_shared_planes_in_layer_order
from ..kernels import mpm
from ..kernels.boundary import fill_face_codes, mirror_pairs, mirror_rows
from ..kernels.shape import MARKERS
from ..kernels.records import GridGeometry, LayerSums, NodeBlock
from .workspace import Workspace

NO_PAIRS = np.zeros((0, 3), np.int64)
#: the suffix of the names of a second kind's layer-ordered sums (grid-coupled FE nodes)
PART = "/part"


def as_rows(array, width):
    """``array`` (rows, width), (rows, n_bodies) with ``width`` 1, or (rows, n_bodies,
    width) as a (rows, n_bodies, width) view."""
    if array.ndim == 3:
        return array
    return array[:, None, :] if array.shape[1] == width else array[:, :, None]


class LevelState:
    """One grid of the hierarchy on this rank (``index`` 0: the coarse grid; k > 0:
    window k - 1), its node block and its nodal arrays of the current step (see
    ``pmpm.kernels.mpm``: ``nodal``, ``gvel``, ``force``, ``gnew``), and the records the
    kernels take: ``geometry`` (GridGeometry) and ``nodes`` (NodeBlock). ``ties`` holds
    a window's tied slaves (set by the tied interface; None on the coarse grid)."""

    def __init__(self, index, level, shape, half_width):
        self.index, self.level = index, level
        self.shape, self.half_width = shape, half_width
        self.work = Workspace()
        self.ties = None
        self.inner = None
        #: the TieSets whose slaves are nodes of this level (set by the tied interface)
        self.slave_ties = []
        #: 1 at this step's tied slaves of this level (set by the tied interface), or None
        self.tied = None
        self.block = None
        self.faces = np.zeros(0, np.uint16)
        #: whether the particles' scatters are layer-ordered (``pmpm.kernels.layered``)
        self.exact = False
        self.kept = {}
        #: the first contact slot of each node plane (set by grid contact each step)
        self.slot_starts = None
        #: the first row of each node plane of the block (layer-ordered sums)
        self.plane_starts = np.zeros(1, np.int64)
        #: the rows of the node planes this rank's slab owns (set with the block)
        self.owned_rows = (0, 0)
        #: a second kind's layer-ordered sums of this step by array name (grid-coupled
        #: FE nodes), added to the array once both are summed over the shared planes
        self.parts = {}

    def build_block(self, slabs, rank, cell_range):
        b = self.block = self.level.block(slabs, rank, *cell_range)
        lv = self.level
        self.plane_starts = plane_starts(b, self.plane_starts)
        self.owned_rows = owned_rows(b, slabs, rank, lv.ratio)
        self.geometry = GridGeometry(lv.origin, lv.inv_h, b.lo, b.strides,
                                     MARKERS[self.shape], self.half_width)
        if len(self.faces) < b.n_nodes:
            self.faces = np.empty(max(b.n_nodes, 1024) * 5 // 4, np.uint16)
        faces = self.faces[:b.n_nodes]
        fill_face_codes(b.shape, b.lo, b.strides, lv.n_cells, lv.boundary, lv.friction, faces)
        self.nodes = NodeBlock(b.shape, b.lo, b.strides, lv.n_cells, lv.boundary, faces,
                               lv.friction)
        #: nodes beyond a plane of symmetry and their images (kernels.boundary)
        self.mirror = mirror_pairs(self.nodes) if lv.halo else NO_PAIRS

    def layer_sums(self, name, width, order, starts=None):
        """The LayerSums record of a scatter into the nodal array ``name`` (``width``
        columns) in the particle ``order``, or None when the sums are not layer-ordered.
        Its ``kept`` sums wait in ``self.kept[name]`` for :meth:`Hierarchy.sum_shared`.
        ``starts``: the first row of each node plane (default: the nodes; the contact
        slots give theirs)."""
        if not self.exact:
            return None
        b = self.block
        if starts is None:
            starts = self.plane_starts
        layers = layer_record(self.work, name, order, b, starts, self.level.halo, width)
        self.kept[name] = layers.kept
        return layers

    def part(self, name, shape):
        """A zeroed array ``shape`` (rows first) for a second kind's layer-ordered sums
        into the array ``name`` (its LayerSums named ``name + PART``): summed over the
        shared planes on its own, then added to the array (:meth:`Hierarchy.sum_shared`,
        ``ContactFields.sum_on_shared_planes``). One rank then adds the two kinds'
        complete sums as every rank count does."""
        flat = self.work.zeros(name + PART, shape[0], int(np.prod(shape[1:])))
        self.parts[name] = flat.reshape(shape)
        return self.parts[name]

    def add_rows(self, name, array, node, x, key, values):
        """``array[node] += values`` row by row (``array`` (n_nodes, c) zeros, ``values``
        (rows, c)); with layer-ordered sums, as a layered scatter adds: per node, the sum
        over the cell layers along the slab axis of the points ``x`` (rows, 3) the rows
        come from, in layer order, of each layer's rows added in ``key`` order (ties by
        value), and the first layers' sums kept for :meth:`Hierarchy.sum_shared` of
        ``name``."""
        if not self.exact:
            np.add.at(array, node, values)
            return
        b, lv, halo = self.block, self.level, self.level.halo
        a = b.slab_axis
        layer = np.floor((x[:, a] - lv.origin[a]) * lv.inv_h).astype(np.int64) - b.lo[a]
        order = np.lexsort(tuple(values.T[::-1]) + (key, layer, node))
        node, layer, values = node[order], layer[order], values[order]
        first = np.ones(len(node), bool)
        first[1:] = (node[1:] != node[:-1]) | (layer[1:] != layer[:-1])
        sums = np.zeros((int(first.sum()), array.shape[1]))
        np.add.at(sums, np.cumsum(first) - 1, values)      # each layer's rows in order
        node, layer = node[first], layer[first]
        np.add.at(array, node, sums)                        # the layers in order
        kept = layer_record(self.work, name, np.zeros(0, np.int64), b, self.plane_starts, halo,
                            array.shape[1]).kept
        k = layer - halo
        on = (k >= 0) & (k < kept.shape[0]) & (node < kept.shape[1])
        kept[k[on], node[on]] = sums[on]
        self.kept[name] = kept

    def kept_planes(self, name, width):
        """The kept first layers' sums of ``name`` as (layer, plane, n1, n2, c)."""
        b = self.block
        kept = self.kept[name]
        return kept.reshape((kept.shape[0],) * 2 + tuple(b.shape[b.order][1:]) + (width,))

    def kept_rows(self, name, shape):
        """The kept first layers' sums of the slot array ``name`` as (layer, rows) +
        ``shape`` (a slot's own shape)."""
        kept = self.kept[name]
        return kept.reshape(kept.shape[:2] + tuple(shape))

    def reflect(self, array, kinds, slot_of=None):
        """Reflect ``array`` (rows, c) or (rows, n_bodies, c) of this level's nodes (or
        of the contact slots ``slot_of``) across the planes of symmetry, its columns of
        ``kinds`` (``pmpm.kernels.boundary.column_kinds``)."""
        if len(self.mirror):
            mirror_rows(as_rows(array, len(kinds)), kinds, self.mirror, self.nodes.boundary,
                        slot_of, self.tied)


def plane_starts(block, kept):
    """The first row of each node plane of ``block`` along its slab axis and the row
    after the last, (n_planes + 1,): ``kept`` if the planes are the same as its."""
    n_planes, stride = int(block.shape[block.slab_axis]), int(block.strides[block.slab_axis])
    if len(kept) == n_planes + 1 and (n_planes == 0 or kept[1] == stride):
        return kept
    return np.arange(n_planes + 1, dtype=np.int64) * stride


def owned_rows(block, slabs, rank, ratio):
    """The rows [first, stop) of ``block`` on the node planes of the slab ``rank`` owns
    (from the cut below it up to the cut above, that one excluded; unbounded at the ends
    of the box): the tied interface adds the ties of these slaves."""
    a = block.slab_axis
    first, last = (ratio * bound for bound in slabs.owned(rank))
    lo, n_planes, stride = int(block.lo[a]), int(block.shape[a]), int(block.strides[a])
    start = 0 if rank == 0 else min(max(first - lo, 0), n_planes)
    stop = n_planes if rank == slabs.size - 1 else min(max(last - lo, 0), n_planes)
    return start * stride, max(stop, start) * stride


def layer_record(work, name, order, block, starts, halo, width):
    """A LayerSums record (``pmpm.kernels.layered``) over the rows ``starts`` gives each
    node plane of ``block`` (nodes, or contact slots), its buffers from ``work``: kept
    layers only where the block shares planes with the rank below."""
    window = 2 + 2 * halo
    n_planes = len(starts) - 1
    reach = min(window, n_planes)
    rows = int(np.max(starts[reach:] - starts[:len(starts) - reach])) if n_planes else 0
    scratch = work.zeros(name + "_layer", rows, width)
    below = any(span[0] == 0 for _, span in block.shared_planes)
    n_kept = 2 * halo + 1 if below else 0
    kept_rows = int(starts[min(n_kept, n_planes)])
    kept = work.zeros(name + "_kept", n_kept * kept_rows, width)
    return LayerSums(order, block.slab_axis, starts, halo, scratch,
                     kept.reshape(n_kept, kept_rows, width))


class Hierarchy:
    """The levels of one rank: the coarse grid first, then the windows; every level uses
    the shape functions ``shape`` (``pmpm.kernels.shape`` code) with the bodies' uGIMP
    ``half_width`` (cells)."""

    def __init__(self, grid_levels, world, shape=0, half_width=None):
        self.world = world
        self.levels = list(grid_levels)
        half_width = np.zeros(1) if half_width is None else half_width
        self.states = [LevelState(i, level, shape, half_width)
                       for i, level in enumerate(self.levels)]
        self.coarse = self.states[0]
        self.windows = self.states[1:]

    def __iter__(self):
        return iter(self.states)

    def build_blocks(self, slabs, rank, cell_ranges):
        for state, cell_range in zip(self.states, cell_ranges):
            state.build_block(slabs, rank, cell_range)

    def zeros(self, name, width):
        """A zeroed nodal array ``name`` (n_nodes, width) on every level."""
        for s in self.states:
            setattr(s, name, s.work.zeros(name, s.block.n_nodes, width))

    def empty(self, name, width):
        """An uninitialised nodal array ``name`` on every level (a kernel fills it)."""
        for s in self.states:
            setattr(s, name, s.work.empty(name, s.block.n_nodes, width))

    def sum_shared(self, name):
        """Sum the nodal array ``name`` on the slab planes shared with neighbours (and a
        second kind's part of it, then added: :meth:`LevelState.part`)."""
        for s in self.states:
            array = getattr(s, name)
            self.sum_array(s, name, array)
            part = s.parts.pop(name, None)
            if part is not None:
                self.sum_array(s, name + PART, part)
                array += part

    def sum_array(self, s, name, array):
        b = s.block
        if s.exact and name in s.kept:          # a layer-ordered scatter's array
            sum_shared_planes_in_layer_order(self.world, b.shared_planes, b.as_planes(array),
                                             s.kept_planes(name, array.shape[1]))
        else:
            sum_shared_planes(self.world, b.shared_planes, b.as_planes(array))

    def reflect(self, name, kinds):
        """Reflect the nodal array ``name`` across the box faces that are planes of
        symmetry on every level (:meth:`LevelState.reflect`)."""
        for s in self.states:
            s.reflect(getattr(s, name), kinds)

    def n_nodes(self):
        return sum(s.block.n_nodes for s in self.states)

    def spans(self, grid, x, level_of):
        """Per level, (-lowest, highest) level cell of the points ``x`` (on levels
        ``level_of``) inside the grid box: float64 (n_levels * 6,), for one MAX
        reduction over ranks."""
        ratios, inv_hs, span = self.span_arrays()
        mpm.level_spans(x, level_of, grid.origin, 1.0 / grid.h, grid.n_cells, ratios,
                        inv_hs, span)
        return span

    def owners_and_spans(self, grid, slabs, rank, x, level_of, owner):
        """:meth:`spans` and each point's owner rank (into ``owner``, -1: left the grid
        box) in one pass over ``x`` (``mpm.owners_and_spans``). Returns (number outside,
        number inside that ``rank`` does not own, spans)."""
        ratios, inv_hs, span = self.span_arrays()
        outside, moving = mpm.owners_and_spans(x, level_of, grid.origin, 1.0 / grid.h,
                                               grid.n_cells, slabs.axis, slabs.bounds, rank,
                                               ratios, inv_hs, owner, span)
        return outside, moving, span

    def span_arrays(self):
        """Each level's ratio and 1 / cell size, and an empty span row (6 per level)."""
        ratios = np.array([lv.ratio for lv in self.levels], np.int64)
        inv_hs = np.array([lv.inv_h for lv in self.levels])
        return ratios, inv_hs, np.empty(6 * len(self.levels))


def cell_ranges(spans):
    """Per level, (lowest, highest) cell from reduced spans (-lowest, highest) * levels;
    an empty range (highest < lowest) where a level has no particle."""
    ranges = []
    for start in range(0, len(spans), 6):
        span = spans[start:start + 6]
        lo, hi = (-span[:3]).astype(np.int64), span[3:6].astype(np.int64)
        if np.any(hi < lo):
            lo, hi = np.zeros(3, np.int64), -np.ones(3, np.int64)
        ranges.append((lo, hi))
    return ranges
