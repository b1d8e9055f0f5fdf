"""Answers that do not move with the CPU (pmpm.kernels.portable): the cube roots that
place split particles and size contact radii and face depths are the C library's on every
machine, not NumPy's SIMD ones, and the split offsets are summed in a fixed order."""
import math

import numpy as np

from pmpm.kernels.portable import cube_roots
from pmpm.particles.split import deformed_offsets, sub_cube_offsets
from pmpm.solver.surface_contact import half_spacing


def test_cube_roots_are_the_c_librarys_to_the_bit():
    values = np.random.default_rng(7).random(20000) * 10.0 ** np.arange(-6, 4).repeat(2000)
    expected = np.array([math.cbrt(v) for v in values])
    assert np.array_equal(cube_roots(values), expected)
    assert np.array_equal(half_spacing(values), 0.5 * expected)


def test_split_offsets_sum_in_the_fixed_order():
    """(j = 0 + j = 2) + j = 1, element by element, for every division."""
    for n in (2, 3, 4):
        F = np.random.default_rng(n).normal(size=(64, 3, 3))
        o = sub_cube_offsets(n)
        got = deformed_offsets(F, o)
        p, k, i = 5, n ** 3 - 1, 2
        want = (F[p, i, 0] * o[k, 0] + F[p, i, 2] * o[k, 2]) + F[p, i, 1] * o[k, 1]
        assert got.shape == (64, n ** 3, 3) and got[p, k, i] == want
        assert np.allclose(got, np.einsum("pij,kj->pki", F, o), rtol=0, atol=1e-15)
