"""One pass over the particles for the history row's observables: per body the sums of
mass, count, momentum moments, energies and failed points, and the bounding box (read by
:func:`pmpm.solver.observe.body_stats`). NumPy took one masked copy per body and column:
69 ms a row for the 169,376-particle Taylor bar, about as long as a step."""
import numpy as np
from numba import njit

from .exact_sum import WIDTH, add

#: the columns of :func:`body_sums`' sums: mass, particles, m x (3), m v (3), kinetic,
#: internal, plastic work, failed particles
N_SUMS = 12


#: particles summed into a partial before it joins the total: the rounding then grows
#: with n / BLOCK + BLOCK, not with n (NumPy's pairwise sums did better still; a plain
#: running sum put the 169,376-particle bar's centroid 3e-12 off, this 2e-14)
BLOCK = 256


@njit(cache=True)
def body_sums(body, mass, x, v, e_int, w_p, damage, n_bodies):
    """(sums (n_bodies, N_SUMS), box (n_bodies, 6)): per body the sums above and
    (-min, max) of the positions, -inf where a body has no particle here."""
    sums = np.zeros((n_bodies, N_SUMS))
    part = np.zeros((n_bodies, N_SUMS))
    box = np.full((n_bodies, 6), -np.inf)
    n = mass.shape[0]
    for start in range(0, n, BLOCK):
        for p in range(start, min(start + BLOCK, n)):
            b, m = body[p], mass[p]
            v0, v1, v2 = v[p, 0], v[p, 1], v[p, 2]
            part[b, 0] += m
            part[b, 1] += 1.0
            for a in range(3):
                part[b, 2 + a] += m * x[p, a]
                box[b, a] = max(box[b, a], -x[p, a])
                box[b, 3 + a] = max(box[b, 3 + a], x[p, a])
            part[b, 5] += m * v0
            part[b, 6] += m * v1
            part[b, 7] += m * v2
            part[b, 8] += 0.5 * m * (v0 * v0 + v1 * v1 + v2 * v2)
            part[b, 9] += m * e_int[p]
            part[b, 10] += m * w_p[p]
            if damage[p] >= 1.0:
                part[b, 11] += 1.0
        sums += part
        part[:] = 0.0
    return sums, box


@njit(cache=True)
def kinetic_and_internal(mass, v, e_int):
    """(sum 1/2 m |v|^2, sum m e_int) over the particles, in blocks as body_sums."""
    kinetic, internal = 0.0, 0.0
    n = mass.shape[0]
    for start in range(0, n, BLOCK):
        k, e = 0.0, 0.0
        for p in range(start, min(start + BLOCK, n)):
            m = mass[p]
            k += 0.5 * m * (v[p, 0] * v[p, 0] + v[p, 1] * v[p, 1] + v[p, 2] * v[p, 2])
            e += m * e_int[p]
        kinetic += k
        internal += e
    return kinetic, internal


@njit(cache=True)
def mass_moment_along(mass, x, direction):
    """sum m (x . direction) over the particles, in blocks as body_sums (the
    gravitational potential is minus this with direction = g)."""
    total = 0.0
    n = mass.shape[0]
    for start in range(0, n, BLOCK):
        part = 0.0
        for p in range(start, min(start + BLOCK, n)):
            part += mass[p] * (x[p, 0] * direction[0] + x[p, 1] * direction[1] +
                               x[p, 2] * direction[2])
        total += part
    return total


# -- exact sums (grid.exact_sums: the same bits on any rank count) ----------------------
# The same sums as above, each term added exactly to an accumulator
# (pmpm.kernels.exact_sum) instead of to a block's partial: the terms are the same
# products as above, rounded once when the ranks' sums are added (pmpm.solver.observe).

@njit(cache=True)
def body_sums_exact(body, mass, x, v, e_int, w_p, damage, n_bodies):
    """(acc (n_bodies * N_SUMS, WIDTH), box (n_bodies, 6)): :func:`body_sums`' columns
    as exact accumulators, body b's column j at row b * N_SUMS + j, and the box."""
    acc = np.zeros((n_bodies * N_SUMS, WIDTH), np.int64)
    box = np.full((n_bodies, 6), -np.inf)
    for p in range(mass.shape[0]):
        b, m = body[p], mass[p]
        r = b * N_SUMS
        v0, v1, v2 = v[p, 0], v[p, 1], v[p, 2]
        add(acc, r, m)
        add(acc, r + 1, 1.0)
        for a in range(3):
            add(acc, r + 2 + a, m * x[p, a])
            box[b, a] = max(box[b, a], -x[p, a])
            box[b, 3 + a] = max(box[b, 3 + a], x[p, a])
        add(acc, r + 5, m * v0)
        add(acc, r + 6, m * v1)
        add(acc, r + 7, m * v2)
        add(acc, r + 8, 0.5 * m * (v0 * v0 + v1 * v1 + v2 * v2))
        add(acc, r + 9, m * e_int[p])
        add(acc, r + 10, m * w_p[p])
        if damage[p] >= 1.0:
            add(acc, r + 11, 1.0)
    return acc, box


@njit(cache=True)
def energy_sums_exact(mass, v, e_int):
    """acc (3, WIDTH): the kinetic and internal energy of :func:`kinetic_and_internal`
    as exact accumulators (the third column, hourglass, stays empty: particles have
    none)."""
    acc = np.zeros((3, WIDTH), np.int64)
    for p in range(mass.shape[0]):
        m = mass[p]
        add(acc, 0, 0.5 * m * (v[p, 0] * v[p, 0] + v[p, 1] * v[p, 1] + v[p, 2] * v[p, 2]))
        add(acc, 1, m * e_int[p])
    return acc


@njit(cache=True)
def moment_along_exact(mass, x, direction, sign):
    """acc (1, WIDTH): ``sign`` times :func:`mass_moment_along` as an exact
    accumulator (sign -1: the gravitational potential with direction = g)."""
    acc = np.zeros((1, WIDTH), np.int64)
    for p in range(mass.shape[0]):
        add(acc, 0, sign * (mass[p] * (x[p, 0] * direction[0] + x[p, 1] * direction[1] +
                                       x[p, 2] * direction[2])))
    return acc
