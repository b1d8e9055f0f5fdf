"""Global observables: energies and per-body mass, centroid, velocity and bounding box.

With ``grid.exact_sums`` every sum over the ranks here is exact
(:mod:`pmpm.kernels.exact_sum`): each rank adds its terms exactly to accumulators, every
rank's sums are added as integers and rounded once (:func:`exact_totals`), so
history.csv, forces.csv and summary.json hold the same bits on any rank count. Without,
each rank sums in blocks and one SUM reduction adds the ranks' sums (cheaper, not
exact)."""
import numpy as np

from ..kernels import exact_sum
from ..kernels.observe import (N_SUMS, body_sums, body_sums_exact, energy_sums_exact,
                               kinetic_and_internal)


def particle_energies(particles):
    """(kinetic, internal) energy of these particles (this rank's)."""
    p = particles
    return kinetic_and_internal(p.mass, p.v, p.e_int)


def particle_energy_sums(particles):
    """This rank's particles' (kinetic, internal, hourglass = 0) as an exact
    accumulator (3 columns)."""
    p = particles
    return energy_sums_exact(p.mass, p.v, p.e_int)


def exact_totals(world, accumulators):
    """The correctly rounded sums over all ranks of the columns of ``accumulators``
    (this rank's exact accumulators, pmpm.kernels.exact_sum, the same shapes on every
    rank; collective: one SUM reduction of their bins, exact as integers), as float
    arrays of their shapes less the bins: the same bits on every rank and any rank
    count."""
    flat = [acc.reshape(-1, exact_sum.WIDTH) for acc in accumulators]
    for columns in flat:
        exact_sum.carry_all(columns)
    every = np.concatenate(flat) if flat else exact_sum.zeros(0)
    every = world.sum(every) if world.size > 1 else every
    totals = np.array([exact_sum.rounded(column) for column in every])
    ends = np.cumsum([len(columns) for columns in flat])[:-1]
    return [part.reshape(acc.shape[:-1])
            for part, acc in zip(np.split(totals, ends), accumulators)]


def body_stats(world, particles, names, exact=False):
    """Per body: mass, n_particles, centroid, velocity (mass-weighted), bbox_min/max,
    energy (kinetic, internal, and plastic: the plastic work sum m w_p, a part of the
    internal energy) and n_failed (particles with damage >= 1); ``exact``: the sums
    exact (:func:`exact_totals`)."""
    p = particles
    if exact:
        acc, box = body_sums_exact(p.body, p.mass, p.x, p.v, p.e_int, p.w_p, p.damage,
                                   len(names))
        sums = exact_totals(world, [acc])[0].reshape(len(names), N_SUMS)
    else:
        sums, box = body_sums(p.body, p.mass, p.x, p.v, p.e_int, p.w_p, p.damage,
                              len(names))
        sums = world.sum(sums)
    box = world.max(box)
    stats = {}
    for b, name in enumerate(names):
        mass = sums[b, 0]
        safe = mass if mass > 0 else 1.0
        stats[name] = {"mass": mass, "n_particles": int(sums[b, 1]),
                       "centroid": (sums[b, 2:5] / safe).tolist(),
                       "velocity": (sums[b, 5:8] / safe).tolist(),
                       "bbox_min": (-box[b, :3]).tolist(), "bbox_max": box[b, 3:].tolist(),
                       "energy": {"kinetic": float(sums[b, 8]),
                                  "internal": float(sums[b, 9]),
                                  "plastic": float(sums[b, 10])},
                       "n_failed": int(sums[b, 11])}
    return stats


#: the columns of :func:`fem_sums_exact` per body, in pmpm.solver.fem_bodies.body_entry's
#: order: mass, m x (3), m v (3), elements, nodes, kinetic, internal, hourglass, plastic
#: work, failed elements
FEM_SUMS = 14


def fem_sums_exact(n_bodies, nodes, elements):
    """An exact accumulator (n_bodies * FEM_SUMS, WIDTH) of FE bodies' sums, body b's
    column j at row b * FEM_SUMS + j. ``nodes``: (body, mass, x, v) of the nodes this
    rank counts; ``elements``: (body, mass, e_int, hourglass energy, w_p, damage) of its
    elements. Each term is one elementwise product, the same bits on any rank."""
    acc = exact_sum.zeros(n_bodies * FEM_SUMS)
    node_body, m, x, v = nodes
    element_body, element_mass, e_int, hourglass, w_p, damage = elements
    for b in range(n_bodies):
        r = b * FEM_SUMS
        mine = node_body == b
        mb, xb, vb = m[mine], x[mine], v[mine]
        columns = [mb, *(mb * xb[:, d] for d in range(3)), *(mb * vb[:, d] for d in range(3))]
        for j, terms in enumerate(columns):
            exact_sum.add_terms(acc, r + j, np.ascontiguousarray(terms))
        exact_sum.add_terms(acc, r + 8, np.ones(np.count_nonzero(mine)))
        exact_sum.add_terms(acc, r + 9, kinetic_terms(mb, vb))
        owns = element_body == b
        em = element_mass[owns]
        exact_sum.add_terms(acc, r + 7, np.ones(np.count_nonzero(owns)))
        exact_sum.add_terms(acc, r + 10, em * e_int[owns])
        exact_sum.add_terms(acc, r + 11, np.ascontiguousarray(hourglass[owns]))
        exact_sum.add_terms(acc, r + 12, em * w_p[owns])
        exact_sum.add_terms(acc, r + 13, np.ones(np.count_nonzero(damage[owns] >= 1.0)))
    return acc


def kinetic_terms(mass, v):
    """1/2 m |v|^2 per point, as the particle kernels compute it (elementwise, in that
    order: no BLAS, whose blocking could round a row differently by its position)."""
    return 0.5 * mass * (v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def node_energy_sums(mass, v, element_mass, e_int, hourglass, removed_hourglass):
    """(kinetic, internal, hourglass) of FE nodes (``mass``, ``v``: those this rank
    counts) and elements as an exact accumulator (3 columns)."""
    acc = exact_sum.zeros(3)
    exact_sum.add_terms(acc, 0, kinetic_terms(mass, v))
    exact_sum.add_terms(acc, 1, element_mass * e_int)
    exact_sum.add_terms(acc, 2, np.append(hourglass, float(removed_hourglass)))
    return acc


def potential_sums(mass, x, gravity):
    """-sum m g.x of points as an exact accumulator (1 column)."""
    g = np.asarray(gravity, np.float64)
    acc = exact_sum.zeros(1)
    exact_sum.add_terms(acc, 0, -(mass * (x[:, 0] * g[0] + x[:, 1] * g[1] + x[:, 2] * g[2])))
    return acc
