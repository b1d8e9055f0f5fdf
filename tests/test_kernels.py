"""Serial tests of the step kernels on small arrays."""
import numpy as np
import pytest

from pmpm.grid import LocalBlock, FIXED, SLIP
from pmpm.comm.slabs import Slabs
from pmpm.kernels import mpm
from pmpm.kernels.boundary import fill_face_codes
from pmpm.kernels.records import (BodyMaterials, ExternalLoads, GridGeometry, NodeBlock,
                                  PointState)
from pmpm.materials.state import MaterialState
from pmpm.kernels.shape import (BSPLINE, GIMP, LINEAR, MARKERS, MAX_NODES, axis_stencil,
                                axis_weights, stencil)
from pmpm.materials.catalog import pack
from numba import njit


@njit
def _shape_of(x, p, origin, inv_h, lo, strides, kind, lp):
    nodes, axes = np.empty(MAX_NODES, np.int64), np.empty((9, 3))
    w, gx, gy, gz = (np.empty(MAX_NODES), np.empty(MAX_NODES), np.empty(MAX_NODES),
                     np.empty(MAX_NODES))
    reach = stencil(x, p, origin, inv_h, lo, strides, kind, lp, axes, nodes, w, gx, gy, gz)
    return nodes[:reach], w[:reach], gx[:reach], gy[:reach], gz[:reach]


def block(n=4, halo=0):
    return LocalBlock(np.full(3, -halo, np.int64), np.full(3, n + 1 + 2 * halo), 0, [])


SHAPES = [(LINEAR, 0.0, 8), (GIMP, 0.25, 27), (GIMP, 0.5, 27), (BSPLINE, 0.0, 27)]


@pytest.mark.parametrize("kind, lp, reach", SHAPES)
def test_shape_functions_partition_unity_and_reproduce_linear_fields(kind, lp, reach):
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.uniform(0.1, 3.9, size=(50, 3)),
                        [[1.0, 2.5, 1.5], [1.25, 1.75, 2.4999999]]])   # on nodes, mid-cell
    b = block(halo=1)
    for p in range(len(x)):
        nodes, w, gx, gy, gz = _shape_of(x, p, np.zeros(3), 1.0, b.lo, b.strides, kind, lp)
        assert len(nodes) == reach and np.all(w >= 0.0)
        assert w.sum() == pytest.approx(1.0, abs=1e-14)
        assert abs(gx.sum()) + abs(gy.sum()) + abs(gz.sum()) < 1e-13
        coords = np.stack(np.unravel_index(nodes, tuple(b.shape)), axis=1) + b.lo
        assert w @ coords == pytest.approx(x[p], abs=1e-12)          # reproduces x
        grad = np.stack([gx, gy, gz]) @ coords                        # d x_i / d x_j = I
        assert grad == pytest.approx(np.eye(3), abs=1e-12)


def _ugimp_definition(r, lp):
    """uGIMP's weight and slope at offset r (cells), half-width lp: the hat max(0, 1 - |t|)
    averaged over [r - lp, r + lp] (its running integral at both ends), and for lp <= 0.5
    also Bardenhagen and Kober's three pieces (pmpm.kernels.shape's docstring)."""
    def running(t):
        c = min(abs(t), 1.0)
        return 0.5 + np.sign(t) * (c - 0.5 * c * c)

    def hat(t):
        return max(0.0, 1.0 - abs(t))

    weight = (running(r + lp) - running(r - lp)) / (2 * lp)
    slope = (hat(r + lp) - hat(r - lp)) / (2 * lp)
    u = abs(r)
    if lp <= 0.5 and u < lp:
        assert weight == pytest.approx(1.0 - (r * r + lp * lp) / (2 * lp), abs=1e-15)
    elif lp <= 0.5 and u <= 1.0 - lp:
        assert weight == pytest.approx(1.0 - u, abs=1e-15)
    elif lp <= 0.5 and u < 1.0 + lp:
        assert weight == pytest.approx((1.0 + lp - u) ** 2 / (4 * lp), abs=1e-15)
    return weight, slope


@pytest.mark.parametrize("lp", [0.5, 0.25, 1 / 6, 0.125, 0.37, 0.75, 1.4])
def test_ugimp_weights_match_the_piecewise_definition_and_sum_to_one(lp):
    """The closed form of the three weights (for lp <= 0.5 the middle one is what the
    outer two leave; node by node beyond) against the definition, over offsets across a
    cell, to 1e-15; up to half a cell of half-width the three weights hold all of the
    particle and sum to one (a particle wider than a cell, from a converted element
    larger than two cells, reaches a fourth node that the 27-node stencil leaves out)."""
    axes = np.zeros((9, 3))
    for s in np.linspace(3.0, 4.0, 401)[:-1]:
        first, count = _axis_stencil(s, GIMP, lp, axes)
        assert count == 3
        for j in range(3):
            weight, slope = _ugimp_definition(s - (first + j), lp)
            assert axes[0, j] == pytest.approx(weight, abs=1e-15)
            assert axes[1, j] == pytest.approx(slope, abs=1e-14)
        if lp <= 0.5:
            assert abs(axes[0].sum() - 1.0) <= 2.3e-16     # the middle is 1 - w0 - w2
            assert abs(axes[1].sum()) <= 1e-15
        weights_only = np.zeros((9, 3))
        _axis_weights(s, GIMP, lp, weights_only)
        assert np.array_equal(weights_only[0], axes[0])


@njit
def _axis_stencil(s, kind, lp, axes):
    return axis_stencil(s, kind, lp, axes, 0)


@njit
def _axis_weights(s, kind, lp, axes):
    return axis_weights(s, kind, lp, axes, 0)


def _gradient_field(x, b, kind, lp):
    nodes, _, gx, _, _ = _shape_of(np.array([x]), 0, np.zeros(3), 1.0, b.lo, b.strides,
                                   kind, lp)
    field = np.zeros(b.n_nodes)
    np.add.at(field, nodes, gx)
    return field


@pytest.mark.parametrize("kind, lp", [(GIMP, 0.25), (GIMP, 0.5), (BSPLINE, 0.0)])
@pytest.mark.parametrize("plane", [2.0, 2.5])        # a cell face, a cell's mid-plane
def test_smooth_shape_gradients_do_not_jump_when_a_particle_crosses(kind, lp, plane):
    b = block(halo=1)
    below = _gradient_field([plane - 1e-7, 2.5, 2.5], b, kind, lp)
    above = _gradient_field([plane + 1e-7, 2.5, 2.5], b, kind, lp)
    assert np.abs(below - above).max() < 1e-5
    hat_below = _gradient_field([2.0 - 1e-7, 2.5, 2.5], b, LINEAR, 0.0)
    hat_above = _gradient_field([2.0 + 1e-7, 2.5, 2.5], b, LINEAR, 0.0)
    assert np.abs(hat_below - hat_above).max() > 0.4      # the hat's jump, for contrast


@pytest.mark.parametrize("shape", [LINEAR, GIMP, BSPLINE])
def test_particle_to_grid_conserves_mass_and_momentum(shape):
    rng = np.random.default_rng(2)
    n = 200
    x = rng.uniform(0.0, 4.0, size=(n, 3))
    v = rng.normal(size=(n, 3))
    mass = rng.uniform(1, 2, n)
    b = block(halo=1)
    nodal = np.zeros((b.n_nodes, mpm.NODAL_COMPONENTS))
    points = PointState(x, v, mass, np.zeros(n, np.int32), np.zeros(n, np.int32))
    mpm.particles_to_grid(points, np.zeros(1, np.bool_), GridGeometry(np.zeros(3), 1.0, b.lo,
                          b.strides, MARKERS[shape], np.full(1, 0.25)), nodal, 0)
    assert nodal[:, 0].sum() == pytest.approx(mass.sum(), rel=1e-13)
    assert nodal[:, 1:4].sum(axis=0) == pytest.approx(mass @ v, rel=1e-12, abs=1e-12)


def test_fixed_and_slip_faces_constrain_nodal_velocity():
    b = block(2)
    nodal = np.zeros((b.n_nodes, mpm.NODAL_COMPONENTS))
    nodal[:, 0] = 1.0
    nodal[:, 1:4] = [1.0, 2.0, 3.0]
    bc = np.array([FIXED, 0, 0, SLIP, 0, 0], np.int64)      # x- fixed, y+ slip
    gvel = np.zeros((b.n_nodes, 3))
    n_cells = np.full(3, 2, np.int64)
    faces = np.zeros(b.n_nodes, np.uint16)
    fill_face_codes(b.shape, b.lo, b.strides, n_cells, bc, np.zeros(6), faces)
    mpm.nodal_velocities(nodal, NodeBlock(b.shape, b.lo, b.strides, n_cells, bc, faces, np.zeros(6)), 0.0,
                         gvel)
    planes = gvel.reshape(3, 3, 3, 3)
    assert np.all(planes[0] == 0.0)                            # x = 0 fixed
    assert np.all(planes[1:, 2, :, 1] == 0.0)                  # y = top: no normal velocity
    assert np.all(planes[1:, 2, :, 0] == 1.0) and np.all(planes[1:, 2, :, 2] == 3.0)
    assert np.all(planes[1:, :2] == [1.0, 2.0, 3.0])


def test_internal_forces_of_uniform_stress_cancel_inside():
    """A uniform stress gives zero net nodal force on interior nodes and a total of zero
    (elastic body at rest: the stress update leaves the stress as it is)."""
    d = 0.5
    axes = [np.arange(d / 2, 4.0, d)] * 3
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    n = len(x)
    b = block()
    code, row = pack({"model": "elastic", "rho": 1.0, "E": 1e3, "nu": 0.25})
    stress = np.tile([100.0, 50.0, 20.0, 10.0, 5.0, 2.0], (n, 1))
    F = np.tile(np.eye(3).ravel(), (n, 1))
    zeros = [np.zeros(n) for _ in range(6)]     # eps_p, e_int, temp, q, damage, w_p
    force = np.zeros((b.n_nodes, 3))
    points = PointState(x, np.zeros((n, 3)), np.full(n, d ** 3), np.zeros(n, np.int32),
                        np.zeros(n, np.int32))
    mat = MaterialState(stress, F, np.ones(n), *zeros)
    bodies = BodyMaterials(np.array([code]), row[None, :], np.zeros(1, np.bool_))
    loads = ExternalLoads(np.zeros(3), np.zeros((1, 3)), np.full(n, -1, np.int32), np.zeros(n))
    mpm.stress_and_forces(points, mat, bodies, loads, 1e-6, 1.0,
                          GridGeometry(np.zeros(3), 1.0, b.lo, b.strides, (), np.zeros(1)),
                          np.zeros((b.n_nodes, 3)), force, None, 0, True, True)
    assert np.all(stress == [100.0, 50.0, 20.0, 10.0, 5.0, 2.0])
    assert np.abs(force.sum(axis=0)).max() < 1e-10
    interior = force.reshape(5, 5, 5, 3)[1:-1, 1:-1, 1:-1]
    assert np.abs(interior).max() < 1e-10
    assert np.abs(force).max() > 1.0                          # the boundary nodes carry it


def test_slab_blocks_share_planes_with_neighbours():
    slabs = Slabs(0, [0, 3, 7, 10])
    lo, hi = np.array([1, 0, 0]), np.array([8, 4, 4])
    blocks = [LocalBlock.for_rank(slabs, r, lo, hi) for r in range(3)]
    assert [b.lo[0] for b in blocks] == [1, 3, 7]
    assert [b.shape[0] for b in blocks] == [3, 5, 3]
    assert blocks[0].shared_planes == [(1, (2, 3))]
    assert blocks[1].shared_planes == [(0, (0, 1)), (2, (4, 5))]
    assert blocks[2].shared_planes == [(1, (0, 1))]
    assert all(list(b.shape[1:]) == [6, 6] for b in blocks)     # cells 0..4 -> nodes 0..5


def test_a_halo_widens_the_block_and_shares_three_planes_around_a_slab_plane():
    slabs = Slabs(0, [0, 3, 7, 10])
    lo, hi = np.array([1, 0, 0]), np.array([8, 4, 4])
    blocks = [LocalBlock.for_rank(slabs, r, lo, hi, halo=1) for r in range(3)]
    assert [b.lo[0] for b in blocks] == [0, 2, 6]
    assert [b.shape[0] for b in blocks] == [5, 7, 5]
    assert blocks[0].shared_planes == [(1, (2, 5))]                  # nodes 2, 3, 4
    assert blocks[1].shared_planes == [(0, (0, 3)), (2, (4, 7))]     # 2..4 and 6..8
    assert blocks[2].shared_planes == [(1, (0, 3))]                  # nodes 6, 7, 8
    assert all(list(b.lo[1:]) == [-1, -1] and list(b.shape[1:]) == [8, 8] for b in blocks)


def owners_and_spans_reference(x, level, origin, inv_h, n_cells, bounds, rank, ratios,
                               inv_hs):
    """Owners, counts and spans the slow way: per particle, in NumPy."""
    cells = np.floor((x - origin) * inv_h)
    inside = np.all((cells >= 0) & (cells < n_cells), axis=1)
    owner = np.where(inside, np.searchsorted(bounds[1:-1], cells[:, 0], side="right"), -1)
    span = np.full(6 * len(ratios), -(2.0 ** 62))
    for lv in range(len(ratios)):
        mine = inside & (level == lv)
        if mine.any():
            c = np.minimum(np.floor((x[mine] - origin) * inv_hs[lv]),
                           n_cells * ratios[lv] - 1.0)
            span[6 * lv:6 * lv + 3] = (-c).max(axis=0)
            span[6 * lv + 3:6 * lv + 6] = c.max(axis=0)
    moving = np.count_nonzero((owner >= 0) & (owner != rank))
    return owner, np.count_nonzero(owner < 0), moving, span


@pytest.mark.parametrize("n_levels", [1, 2])
def test_owners_and_spans_are_classify_and_level_spans_in_one_pass(n_levels):
    """The end of the step's fused pass gives the owners, the counts outside and moving,
    and the spans of classify_particles and level_spans (and of a NumPy reference), with
    points outside the box and on two levels."""
    rng = np.random.default_rng(3)
    origin, h = np.array([-1.0, 0.0, 0.5]), 0.25
    n_cells = np.array([16.0, 8.0, 12.0])
    x = origin + rng.uniform(-0.5, 1.1, (500, 3)) * n_cells * h
    level = (rng.uniform(size=500) < 0.4).astype(np.int32) if n_levels == 2 else \
        np.zeros(500, np.int32)
    ratios = np.array([1, 2][:n_levels], np.int64)
    inv_hs = 1.0 / h * ratios.astype(np.float64)
    bounds = np.array([0, 5, 11, 16], np.int64)
    for rank in range(3):
        owner, span = np.empty(500, np.int64), np.empty(6 * n_levels)
        outside, moving = mpm.owners_and_spans(x, level, origin, 1.0 / h, n_cells, 0, bounds,
                                               rank, ratios, inv_hs, owner, span)
        owner1, span1 = np.empty(500, np.int64), np.empty(6 * n_levels)
        counts1 = mpm.classify_particles(x, origin, 1.0 / h, n_cells, 0, bounds, rank, owner1)
        mpm.level_spans(x, level, origin, 1.0 / h, n_cells, ratios, inv_hs, span1)
        ref_owner, ref_outside, ref_moving, ref_span = owners_and_spans_reference(
            x, level, origin, 1.0 / h, n_cells, bounds, rank, ratios, inv_hs)
        assert 0 < outside < 500 and 0 < moving < 500 - outside
        assert (outside, moving) == counts1 == (ref_outside, ref_moving)
        np.testing.assert_array_equal(owner, owner1)
        np.testing.assert_array_equal(owner, ref_owner)
        np.testing.assert_array_equal(span, span1)
        np.testing.assert_array_equal(span, ref_span)
