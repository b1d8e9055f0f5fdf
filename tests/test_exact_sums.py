"""Layer-ordered scatter sums (pmpm.kernels.layered): a node's value is the fold, in cell
layer order along the slab axis, of each layer's sum over its particles in canonical
order; and two slab blocks, their shared planes folded with the upper block's kept
layers, give the one-block arrays to the bit (what 2 ranks do, without MPI)."""
import numpy as np
import pytest

from pmpm.comm.exchange import fold_layers
from pmpm.comm.slabs import Slabs
from pmpm.grid import LocalBlock
from pmpm.kernels import mpm
from pmpm.kernels.records import GridGeometry, PointState
from pmpm.kernels.shape import BSPLINE, GIMP, HALO, LINEAR, MARKERS
from pmpm.solver.levels import layer_record
from pmpm.solver.workspace import Workspace

N_CELLS = 8
WIDTH = mpm.NODAL_COMPONENTS


def particles(n=400, seed=3):
    """Points over the box, in no particular order, with shuffled ids."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, N_CELLS, size=(n, 3))
    return (PointState(x, rng.normal(size=(n, 3)), rng.uniform(0.5, 2.0, n),
                       np.zeros(n, np.int32), np.zeros(n, np.int32)),
            rng.permutation(n).astype(np.int64) * 7 + 5)


def canonical(pts, ids, axis):
    cells = mpm.slab_cell_keys(pts.x, np.zeros(3), 1.0, np.full(3, N_CELLS, np.int64), axis)
    return np.lexsort((ids, cells))


def geometry(block, shape):
    return GridGeometry(np.zeros(3), 1.0, block.lo, block.strides, MARKERS[shape],
                        np.full(1, 0.25))


def layered_scatter(pts, order, block, shape):
    """The nodal array of a layer-ordered scatter of the points ``order`` on ``block``,
    and its LayerSums record."""
    nodal = np.zeros((block.n_nodes, WIDTH))
    axis = block.slab_axis
    starts = np.arange(block.shape[axis] + 1, dtype=np.int64) * block.strides[axis]
    layers = layer_record(Workspace(), "nodal", order, block, starts, HALO[shape], WIDTH)
    mpm.particles_to_grid(pts, np.zeros(1, np.bool_), geometry(block, shape), nodal, 0,
                          None, layers)
    return nodal, layers


def whole_block(shape, axis):
    halo = HALO[shape]
    return LocalBlock(np.full(3, -halo, np.int64), np.full(3, N_CELLS + 1 + 2 * halo), axis,
                      [])


@pytest.mark.parametrize("axis", [0, 2])
@pytest.mark.parametrize("shape", [LINEAR, GIMP, BSPLINE])
def test_layered_scatter_is_the_fold_of_the_layer_sums(shape, axis):
    pts, ids = particles()
    order = canonical(pts, ids, axis)
    b = whole_block(shape, axis)
    nodal, _ = layered_scatter(pts, order, b, shape)
    geo, rigid = geometry(b, shape), np.zeros(1, np.bool_)
    layer_sums = {}
    for p in order:                 # each particle's contributions, added in numpy
        one = PointState(*(column[p:p + 1] for column in pts))
        own = np.zeros_like(nodal)
        mpm.particles_to_grid(one, rigid, geo, own, 0, None, None)
        layer = int(np.floor(pts.x[p, axis]))
        layer_sums[layer] = layer_sums.get(layer, 0.0) + own
    expected = np.zeros_like(nodal)
    for layer in sorted(layer_sums):
        expected += layer_sums[layer]
    assert np.array_equal(nodal, expected)
    assert nodal[:, 0].sum() == pytest.approx(pts.mass.sum(), rel=1e-13)


@pytest.mark.parametrize("shape", [LINEAR, GIMP, BSPLINE])
def test_two_slabs_folded_on_their_shared_planes_give_the_one_block_sums(shape):
    pts, ids = particles(seed=4)
    axis, halo = 1, HALO[shape]
    order = canonical(pts, ids, axis)
    one, _ = layered_scatter(pts, order, whole_block(shape, axis), shape)
    slabs = Slabs(axis, [0, 3, N_CELLS])
    owner = slabs.owner_of_cells(np.floor(pts.x[:, axis]).astype(np.int64))
    lo, hi = np.zeros(3, np.int64), np.full(3, N_CELLS - 1, np.int64)
    blocks = [LocalBlock.for_rank(slabs, r, lo, hi, 1, halo) for r in range(2)]
    parts = [layered_scatter(pts, order[owner[order] == r], blocks[r], shape)
             for r in range(2)]
    planes = [b.as_planes(nodal) for b, (nodal, _) in zip(blocks, parts)]
    (_, (first0, stop0)), = blocks[0].shared_planes
    (_, (first1, stop1)), = blocks[1].shared_planes
    kept = parts[1][1].kept.reshape((stop1 - first1,) * 2 + planes[1].shape[1:])
    for k in range(stop1 - first1):         # both slabs reach every shared plane
        assert (planes[0][first0 + k, ..., 0] > 0).any() and (kept[:, k, ..., 0] > 0).any()
    shared = fold_layers(planes[0][first0:stop0], kept)
    planes[0][first0:stop0] = planes[1][first1:stop1] = shared
    whole = whole_block(shape, axis).as_planes(one)
    cut = 3 + halo                      # the slab plane's index in the whole block
    assert np.array_equal(planes[0], whole[:cut + halo + 1])
    assert np.array_equal(planes[1], whole[cut - halo:])


WINDOW_BALL = ["params.cell=2", "params.plate_radius=16", "params.cells_below=6",
               "params.ratio=2", "params.window=8", "params.window_below=4"]


def test_auto_turns_exact_sums_on_for_windows_with_every_shape():
    """The steel ball in a window with contact: ``auto`` is on with the bspline shapes as
    with gimp, and ``true`` is accepted (tests/test_exact_sums_mpi.py: 2 ranks give the
    1-rank answer to the bit)."""
    import os

    from pmpm.case.loader import load_config
    case = os.path.join(os.path.dirname(__file__), "..", "runs", "steel_ball_plate.yaml")
    for shape in ("gimp", "bspline"):
        for value in ("auto", "true"):
            config = load_config(case, WINDOW_BALL + [f"grid.shape_functions={shape}",
                                                      f"grid.exact_sums={value}"],
                                 check_geometry=False)
            assert config.grid.exact_sums, (shape, value)


@pytest.mark.parametrize("halo", [0, 1])
def test_a_slab_without_cells_of_the_range_gets_no_block(halo):
    """The particles end two cells below the slab plane: the rank above gets no node (not
    the halo's planes, which the rank below holds complete without sharing them: an
    inner slave of a window read its empty copy there), the rank below no shared plane."""
    slabs = Slabs(2, [0, 7, 13])
    lo, hi = np.zeros(3, np.int64), np.array([3, 3, 5])
    below, above = (LocalBlock.for_rank(slabs, r, lo, hi, 1, halo) for r in range(2))
    assert below.lo[2] == -halo and below.shape[2] == 7 + 2 * halo
    assert below.shared_planes == [] and above.shared_planes == []
    assert above.n_nodes == 0
