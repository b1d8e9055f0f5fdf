"""The contact searches skip a face before its Newton projection when the face's node box
lies beyond what could make it a pair, or beyond the best face found so far
(pmpm.kernels.surface_contact.beyond_reach). The skip must change no answer: each kernel
is compared here with the same loop run without the skip (its Python function, with
``beyond_reach`` answering False), on crowded random faces where windows, ties and
nearer faces all come into play, to the bit."""
import numpy as np
import pytest

from pmpm.kernels import node_contact as knc
from pmpm.kernels import surface_contact as ksc

BASE = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]])


def crowded_faces(rng, n_faces=80):
    """Small warped faces about a 4 x 4 x 4 box, tilted, some repeated (ties), and
    where they were at the step's start (moved a little)."""
    centres = rng.uniform(0, 4, (n_faces, 3))
    tilt = rng.normal(0, 0.3, (n_faces, 1, 3)) * BASE[None, :, :1]
    faces = centres[:, None, :] + BASE[None] + tilt + rng.normal(0, 0.05, (n_faces, 4, 3))
    faces[n_faces // 2:n_faces // 2 + 10] = faces[:10]          # twins: ties by key
    before = faces + rng.normal(0, 0.02, faces.shape)
    return np.ascontiguousarray(faces), np.ascontiguousarray(before)


def one_bucket(faces, points):
    """A single bucket holding every face."""
    lo = np.minimum(faces.reshape(-1, 3).min(axis=0), points.min(axis=0)) - 1.0
    return (lo, 1e-3, np.ones(3, np.int64), np.array([0, len(faces)], np.int64),
            np.arange(len(faces), dtype=np.int64))


@pytest.fixture
def without_cull(monkeypatch):
    """Run a kernel's Python function with the box skip switched off."""
    def run(module, kernel, *args):
        monkeypatch.setattr(module, "beyond_reach", lambda *a: False)
        return kernel.py_func(*args)
    return run


def points_near(rng, faces, before, n, spread):
    """n points within ``spread`` of the faces' first corners, their positions a step
    before, how far each moved, and how far each face moved."""
    x = faces[rng.integers(0, len(faces), n), 0] + rng.uniform(-spread, spread, (n, 3))
    x0 = x + rng.normal(0, 0.05, (n, 3))
    seg_move = np.empty(len(faces))
    ksc.segment_moves(faces, before, seg_move)
    return x, x0, np.linalg.norm(x - x0, axis=1), seg_move


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_particle_search_finds_the_same_faces_with_the_skip(seed, without_cull):
    rng = np.random.default_rng(seed)
    faces, before = crowded_faces(rng)
    n = 600
    px, px0, moved, seg_move = points_near(rng, faces, before, n, 0.8)
    args = (px, px0, np.zeros(n, np.int64), rng.uniform(0.01, 0.3, n), moved, faces,
            before, seg_move, np.ones(len(faces), np.int64),
            rng.permutation(len(faces)).astype(np.int64),
            np.array([[False, True], [False, False]])) + one_bucket(faces, px)
    seg, geo = np.empty(n, np.int64), np.empty((n, 6))
    seg_ref, geo_ref = np.empty(n, np.int64), np.empty((n, 6))
    found = ksc.find_pairs(*args, seg, geo)
    assert found == without_cull(ksc, ksc.find_pairs, *args, seg_ref, geo_ref)
    assert found > 50
    assert np.array_equal(seg, seg_ref)
    paired = seg >= 0
    assert np.array_equal(geo[paired], geo_ref[paired])


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_node_search_finds_the_same_faces_with_the_skip(seed, without_cull):
    rng = np.random.default_rng(seed)
    faces, before = crowded_faces(rng)
    n = 600
    nx, nx0, nmove, seg_move = points_near(rng, faces, before, n, 0.6)
    depth = rng.uniform(0.1, 0.5, len(faces))
    args = (nx, nx0, nmove, np.zeros(n, np.int64), faces, before, seg_move,
            np.ones(len(faces), np.int64), rng.permutation(len(faces)).astype(np.int64),
            depth, np.array([[False, True], [False, False]]), 0.3) + one_bucket(faces, nx)
    seg, geo = np.empty(n, np.int64), np.empty((n, 6))
    seg_ref, geo_ref = np.empty(n, np.int64), np.empty((n, 6))
    found = knc.find_node_pairs(*args, seg, geo)
    assert found == without_cull(knc, knc.find_node_pairs, *args, seg_ref, geo_ref)
    assert found > 20
    assert np.array_equal(seg, seg_ref)
    paired = seg >= 0
    assert np.array_equal(geo[paired], geo_ref[paired])


def test_the_skip_is_exact_at_the_reach():
    """A point just inside the reach of a face's box is not skipped, one just beyond it
    is."""
    face = np.ascontiguousarray(BASE.astype(float))
    assert not ksc.beyond_reach(face, np.array([0.0, 0.0, 1.0]), 1.0)
    assert ksc.beyond_reach(face, np.array([0.0, 0.0, 1.0 + 1e-6]), 1.0)
    corner = np.array([0.5 + 0.6, 0.5 + 0.8, 0.0])          # 1.0 from the box's corner
    assert not ksc.beyond_reach(face, corner, 1.0)
    assert ksc.beyond_reach(face, corner, 0.999)


def test_the_gathers_give_numpy_bits():
    rng = np.random.default_rng(5)
    x, x0, v = rng.normal(size=(50, 3)), rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    nodes = rng.integers(0, 50, (30, 4)).astype(np.int64)
    seg = [np.empty((30, 4, 3)) for _ in range(3)]
    ksc.gather_segments(x, x0, v, nodes, *seg)
    for got, want in zip(seg, (x, x0, v)):
        assert np.array_equal(got, want[nodes])
    idx = rng.permutation(50)[:20].astype(np.int64)
    moves = np.empty(20)
    ksc.point_moves(x, x0, idx, moves)
    assert np.array_equal(moves, np.linalg.norm(x[idx] - x0[idx], axis=1))
    lo, hi = np.empty(3), np.empty(3)
    ksc.box_bounds(x, x0, lo, hi)
    assert np.array_equal(lo, x.min(axis=0)) and np.array_equal(hi, x0.max(axis=0))
