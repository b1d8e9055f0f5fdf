"""Global observables: energies and per-body mass, centroid, velocity and bounding box."""
import numpy as np


def particle_energies(particles):
    """(kinetic, internal) energy of these particles (this rank's)."""
    p = particles
    kinetic = 0.5 * float(np.sum(p.mass * np.einsum("ij,ij->i", p.v, p.v)))
    internal = float(np.sum(p.mass * p.e_int))
    return kinetic, internal


def body_stats(world, particles, names):
    """Per body: mass, n_particles, centroid, velocity (mass-weighted), bbox_min/max,
    energy (kinetic, internal, and plastic: the plastic work sum m w_p, a part of the
    internal energy) and n_failed (particles with damage >= 1)."""
    p, nb = particles, len(names)
    sums = np.zeros((nb, 12))
    box = np.full((nb, 6), -np.inf)
    for b in range(nb):
        mine = p.body == b
        if not mine.any():
            continue
        m = p.mass[mine]
        v = p.v[mine]
        sums[b] = [m.sum(), mine.sum(), *(m @ p.x[mine]), *(m @ v),
                   0.5 * m @ np.einsum("ij,ij->i", v, v), m @ p.e_int[mine],
                   m @ p.w_p[mine], np.count_nonzero(p.damage[mine] >= 1.0)]
        box[b, :3], box[b, 3:] = -p.x[mine].min(axis=0), p.x[mine].max(axis=0)
    sums, box = world.sum(sums), world.max(box)
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
