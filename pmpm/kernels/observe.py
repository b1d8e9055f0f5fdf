"""One pass over the particles for the history row's observables: per body the sums of
mass, count, momentum moments, energies and failed points, and the bounding box (read by
:func:`pmpm.solver.observe.body_stats`). NumPy took one masked copy per body and column:
69 ms a row for the 169,376-particle Taylor bar, about as long as a step."""
import numpy as np
from numba import njit

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
