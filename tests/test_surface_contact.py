"""Particle-to-surface contact (ICFEMP, seed 004 Sec. 3): the kernels (projection, impulse,
buckets) and small coupled runs of particle blocks on an FEM plate."""
import json
import os

import numpy as np
import pytest

from pmpm.kernels import surface_contact as ksc

HERE = os.path.dirname(os.path.abspath(__file__))

WARPED = np.array([[0.0, 0.0, 0.0], [2.0, 0.1, 0.3], [2.2, 1.9, -0.2], [-0.1, 2.1, 0.4]])


def brute_closest(xf, t, n=801):
    """The closest point of the bilinear face by sampling (xi, eta) on a fine lattice and
    refining around the best sample."""
    lo, hi = np.array([-1.0, -1.0]), np.array([1.0, 1.0])
    for _ in range(6):
        xi, eta = np.meshgrid(np.linspace(lo[0], hi[0], n), np.linspace(lo[1], hi[1], n))
        phi = ksc_shapes(xi.ravel(), eta.ravel())
        r = phi @ xf
        k = np.argmin(((r - t) ** 2).sum(axis=1))
        best = np.array([xi.ravel()[k], eta.ravel()[k]])
        width = (hi - lo) / (n - 1) * 4
        lo, hi = np.maximum(best - width, -1), np.minimum(best + width, 1)
    return best, r[k]


def ksc_shapes(xi, eta):
    return 0.25 * (1 + ksc.XI[None] * xi[:, None]) * (1 + ksc.ETA[None] * eta[:, None])


@pytest.mark.parametrize("t", [[1.0, 1.0, 1.5], [0.3, 1.7, -0.8], [1.9, 0.4, 0.9],
                               [1.2, 0.9, 0.05]])
def test_newton_projection_on_a_warped_face_matches_the_brute_force_closest_point(t):
    t = np.array(t)
    out = np.empty(5)
    g, off = ksc.closest_point(WARPED, t, out)
    best, r_brute = brute_closest(WARPED, t)
    assert np.allclose(out[:2], best, atol=1e-6)
    phi = ksc_shapes(out[:1], out[1:2])[0]
    r = phi @ WARPED
    assert np.linalg.norm(r - r_brute) < 1e-6
    normal = out[2:5]
    assert abs(np.linalg.norm(normal) - 1) < 1e-12
    assert abs(g - normal @ (t - r)) < 1e-12
    assert off < 1e-8              # an interior closest point: t - r along the normal


def test_normal_points_out_of_a_hexahedron_face():
    """FACES are counter-clockwise from outside: the top face of a unit cube has +z."""
    from pmpm.fem.hexahedron import FACES
    cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                     [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    out = np.empty(5)
    for f in range(6):
        xf = cube[FACES[f]]
        centre = xf.mean(axis=0)
        g, _ = ksc.closest_point(xf, centre + 0.3 * (centre - 0.5), out)
        assert g > 0 and np.allclose(out[2:5], (centre - 0.5) / 0.5)


def one_pair(v_p, v_nodes, mu=0.3, m_p=2.0, masses=(1.0, 3.0, 2.0, 5.0), xi=(0.2, -0.4)):
    phi = ksc_shapes(np.array([xi[0]]), np.array([xi[1]]))[0]
    inv_m = 1.0 / np.array(masses)
    impulse = np.empty(3)
    acts = ksc.pair_impulse(m_p, np.array(v_p, float), np.array(v_nodes, float), inv_m,
                            phi, np.array([0.0, 0.0, 1.0]), mu, impulse)
    return acts, impulse, phi, inv_m


def test_the_impulse_conserves_momentum_and_sticks_the_contact_point():
    v_nodes = np.array([[0.1, 0, 0], [0, 0.2, 0], [0, 0, 0.1], [0.3, 0, -0.1]])
    m_p, masses = 2.0, np.array([1.0, 3.0, 2.0, 5.0])
    acts, impulse, phi, inv_m = one_pair([0.05, 0.0, -1.0], v_nodes, mu=10.0)
    assert acts and impulse[2] < 0          # pushes the face in, the particle out
    v_p = np.array([0.05, 0.0, -1.0]) - impulse / m_p
    v_j = v_nodes + phi[:, None] * impulse[None] * inv_m[:, None]
    before = m_p * np.array([0.05, 0.0, -1.0]) + masses @ v_nodes
    after = m_p * v_p + masses @ v_j
    assert np.abs(after - before).max() < 1e-15
    assert np.abs(v_p - phi @ v_j).max() < 1e-14       # stick: C moves with the particle


def test_a_separating_pair_gets_no_impulse():
    acts, impulse, _, _ = one_pair([1.0, 0.0, 0.2], np.zeros((4, 3)))
    assert not acts and not impulse.any()


def test_the_tangential_impulse_is_capped_at_mu_times_the_normal():
    acts, impulse, _, _ = one_pair([3.0, 1.0, -0.5], np.zeros((4, 3)), mu=0.25)
    assert acts
    tangent = np.linalg.norm(impulse[:2])
    assert abs(tangent - 0.25 * abs(impulse[2])) < 1e-14
    assert abs(impulse[0] / impulse[1] - 3.0) < 1e-12  # along the sliding direction


def test_a_rigid_master_takes_the_particle_to_its_velocity():
    impulse = np.empty(3)
    phi = np.full(4, 0.25)
    ksc.pair_impulse(2.0, np.array([0.0, 0.0, -1.0]), np.zeros((4, 3)), np.zeros(4), phi,
                     np.array([0.0, 0.0, 1.0]), 0.0, impulse)
    assert np.allclose(impulse, [0, 0, -2.0])           # m_p (v_p - v_c), m_c infinite


def test_buckets_find_every_segment_a_particle_can_touch():
    """Random small faces and points: find_pairs over the buckets chooses the same face
    as a search over every face."""
    rng = np.random.default_rng(4)
    centres = rng.uniform(0, 10, (60, 3))
    base = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]])
    faces = centres[:, None, :] + base[None] + rng.normal(0, 0.05, (60, 4, 3))
    px = centres[rng.integers(0, 60, 400)] + rng.uniform(-0.7, 0.7, (400, 3)) * [1, 1, 0.3]
    radius = np.full(400, 0.25)
    reach = 0.5
    lo_s, hi_s = faces.min(axis=1) - reach, faces.max(axis=1) + reach
    lo = lo_s.min(axis=0)
    size = 1.0
    dims = np.ceil((hi_s.max(axis=0) - lo) / size).astype(np.int64)
    start, items = ksc.bucket_segments(lo_s, hi_s, lo, 1 / size, dims)
    args = (px, np.zeros(400, np.int64), radius, faces, np.ones(60, np.int64),
            np.arange(60, dtype=np.int64), np.array([[False, True], [False, False]]))
    seg, geo = np.empty(400, np.int64), np.empty((400, 6))
    n = ksc.find_pairs(*args, lo, 1 / size, dims, start, items, seg, geo)
    every = np.tile(np.arange(60), (1, 1)).astype(np.int64)
    start1 = np.array([0, 60], np.int64)
    seg1, geo1 = np.empty(400, np.int64), np.empty((400, 6))
    big = np.array([1, 1, 1], np.int64)
    n1 = ksc.find_pairs(*args, px.min(axis=0) - 1, 1e-3, big, start1, every.ravel(),
                        seg1, geo1)
    assert n == n1 > 20
    assert (seg == seg1).all()


# -- coupled runs ----------------------------------------------------------------------
def run_case(tmp_path, name, overrides=(), ranks=1):
    """Run a test case; its summary and its output folder."""
    import subprocess
    import sys
    out = tmp_path / name
    cmd = [sys.executable, "-m", "pmpm", os.path.join(HERE, "cases", name + ".yaml"),
           "--output", str(out)]
    for item in overrides:
        cmd += ["--set", item]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe"] + cmd
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    with open(out / "summary.json") as handle:
        return json.load(handle), out
