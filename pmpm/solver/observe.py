"""Global observables: energies and per-body mass, centroid, velocity and bounding box."""

from ..kernels.observe import body_sums, kinetic_and_internal


def particle_energies(particles):
    """(kinetic, internal) energy of these particles (this rank's)."""
    p = particles
    return kinetic_and_internal(p.mass, p.v, p.e_int)


def body_stats(world, particles, names):
    """Per body: mass, n_particles, centroid, velocity (mass-weighted), bbox_min/max,
    energy (kinetic, internal, and plastic: the plastic work sum m w_p, a part of the
    internal energy) and n_failed (particles with damage >= 1)."""
    p = particles
    sums, box = body_sums(p.body, p.mass, p.x, p.v, p.e_int, p.w_p, p.damage, len(names))
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
