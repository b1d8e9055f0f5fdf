"""Probes (``output.probes``): particles followed through a run, each chosen at the start
as its body's particle nearest a point, and sampled at every history row: position,
velocity, stress, eps_p, pressure and von Mises stress (rank 0 writes probe_NAME.csv,
pmpm.io.probes).

A probe's particle is known by its id, so it is found wherever it has migrated; the
choice (the smallest distance, then the lower id) and the sample (one rank holds the
particle, the others add zeros) are the same on any number of ranks. A checkpoint keeps
the ids, so a restart follows the same particles."""
import numpy as np

from ..io.derived import stress_invariants

#: The columns of a sample, after step and time.
COLUMNS = ("x", "y", "z", "vx", "vy", "vz", "sxx", "syy", "szz", "sxy", "syz", "szx",
           "eps_p", "pressure", "von_mises")


class Probes:
    def __init__(self, world, probes, particles, body_names, kept=None):
        """``probes``: the case's output.probes; ``kept``: {name: id} of a checkpoint."""
        self.world = world
        self.names = [probe["name"] for probe in probes]
        kept = kept or {}
        self.ids = np.array([kept[p["name"]] if p["name"] in kept else
                             nearest_particle(world, particles, body_names.index(p["body"]),
                                              p["point"]) for p in probes], np.int64)

    def sample(self, particles):
        """(probes, len(COLUMNS)) values of every probe's particle (collective; a probe
        whose particle has left the grid reads NaN)."""
        values = np.zeros((len(self.ids), len(COLUMNS) + 1))
        rows = {pid: k for k, pid in enumerate(self.ids)}
        for index in np.flatnonzero(np.isin(particles.id, self.ids)):
            k = rows[int(particles.id[index])]
            pressure, von_mises = stress_invariants(particles.stress[index:index + 1])
            values[k, :-1] = [*particles.x[index], *particles.v[index],
                              *particles.stress[index], particles.eps_p[index],
                              pressure[0], von_mises[0]]
            values[k, -1] = 1.0
        values = self.world.sum(values)
        values[values[:, -1] == 0, :-1] = np.nan
        return values[:, :-1]

    def state(self):
        return dict(zip(self.names, (int(i) for i in self.ids)))


def nearest_particle(world, particles, body, point):
    """The id of body ``body``'s particle nearest ``point`` over all ranks (ties: the
    lower id), or -1 when the body has none."""
    mine = np.flatnonzero(particles.body == body)
    best = (np.inf, -1)
    if len(mine):
        d2 = ((particles.x[mine] - np.asarray(point, np.float64)) ** 2).sum(axis=1)
        ids = particles.id[mine]
        k = np.lexsort((ids, d2))[0]
        best = (float(d2[k]), int(ids[k]))
    found = [b for b in world.allgather(best) if b[1] >= 0]
    return min(found)[1] if found else -1
