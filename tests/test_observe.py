"""The history row's one-pass observables (pmpm.kernels.observe) against NumPy."""
import numpy as np

from pmpm.kernels.observe import BLOCK, body_sums, kinetic_and_internal, mass_moment_along


def particles(n=3 * BLOCK + 17, n_bodies=3, seed=4):
    rng = np.random.default_rng(seed)
    return {"body": rng.integers(0, n_bodies - 1, n).astype(np.int32),  # the last is empty
            "mass": rng.random(n), "x": rng.normal(size=(n, 3)), "v": rng.normal(size=(n, 3)),
            "e_int": rng.random(n), "w_p": rng.random(n), "damage": 2 * rng.random(n)}


def reference(p, b):
    mine = p["body"] == b
    m, x, v = p["mass"][mine], p["x"][mine], p["v"][mine]
    sums = [m.sum(), mine.sum(), *(m @ x), *(m @ v), 0.5 * m @ np.einsum("ij,ij->i", v, v),
            m @ p["e_int"][mine], m @ p["w_p"][mine], np.count_nonzero(p["damage"][mine] >= 1)]
    return np.array(sums), np.concatenate([-x.min(axis=0), x.max(axis=0)])


def test_body_sums_match_numpy_per_body_and_leave_an_empty_body_empty():
    p = particles()
    sums, box = body_sums(p["body"], p["mass"], p["x"], p["v"], p["e_int"], p["w_p"],
                          p["damage"], 3)
    for b in range(2):
        want, want_box = reference(p, b)
        np.testing.assert_allclose(sums[b], want, rtol=1e-13, atol=1e-13)
        np.testing.assert_array_equal(box[b], want_box)
    assert not sums[2].any() and np.all(box[2] == -np.inf)


def test_kinetic_and_internal_match_numpy():
    p = particles()
    kinetic, internal = kinetic_and_internal(p["mass"], p["v"], p["e_int"])
    assert np.isclose(kinetic, 0.5 * np.sum(p["mass"] * np.einsum("ij,ij->i", p["v"], p["v"])),
                      rtol=1e-14)
    assert np.isclose(internal, np.sum(p["mass"] * p["e_int"]), rtol=1e-14)
    assert kinetic_and_internal(np.zeros(0), np.zeros((0, 3)), np.zeros(0)) == (0.0, 0.0)


def test_mass_moment_along_a_direction_matches_numpy():
    p = particles()
    g = np.array([0.3, -9.81, 2.0])
    assert np.isclose(mass_moment_along(p["mass"], p["x"], g), p["mass"] @ (p["x"] @ g),
                      rtol=1e-13)
