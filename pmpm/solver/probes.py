"""Probes (``output.probes``), sampled at every history row: position, velocity, stress,
eps_p, pressure and von Mises stress (rank 0 writes probe_NAME.csv, pmpm.io.probes).

* A probe on a particle body follows the particle nearest its point at the start
  (``fixed: false``, the default; LS-DYNA's tracer), or samples at every row the body's
  particle nearest the point then (``fixed: true``: a gauge at a place in space, Uintah's
  point extract without interpolation).
* A probe on an FEM body does the same with the body's FE nodes: position and velocity;
  a node carries no stress, so the stress columns read NaN.

A point is known by its id, so it is found wherever it has migrated; the choice (the
smallest distance, then the lower id) and the sample (one rank holds the point, the
others add zeros) are the same on any number of ranks. A checkpoint keeps the ids of the
followed points, so a restart follows the same ones."""
import numpy as np

from ..io.derived import stress_invariants

#: The columns of a sample, after step and time.
COLUMNS = ("x", "y", "z", "vx", "vy", "vz", "sxx", "syy", "szz", "sxy", "syz", "szx",
           "eps_p", "pressure", "von_mises")


class Probes:
    def __init__(self, world, probes, particles, body_names, kept=None, elements=None):
        """``probes``: the case's output.probes; ``kept``: {name: id} of a checkpoint;
        ``elements``: the FEM bodies (pmpm.solver.fem_bodies.FemBodies) or None."""
        self.world, self.elements = world, elements
        self.names = [probe["name"] for probe in probes]
        self.bodies = [body_names.index(p["body"]) for p in probes]
        self.points = [np.asarray(p["point"], np.float64) for p in probes]
        self.fixed = [bool(p.get("fixed", False)) for p in probes]
        self.on_nodes = [elements is not None and b in elements.body_indices
                         for b in self.bodies]
        kept = kept or {}
        self.ids = np.array([kept[p["name"]] if p["name"] in kept else
                             self.nearest(k, particles) for k, p in enumerate(probes)],
                            np.int64)

    def nearest(self, k, particles):
        """The id of probe k's body's particle or FE node nearest its point (collective)."""
        if self.on_nodes[k]:
            fem = self.elements
            return nearest_id(self.world, fem.x, fem.node_id,
                              (fem.node_body == self.bodies[k]) & fem.owned, self.points[k])
        return nearest_id(self.world, particles.x, particles.id,
                          particles.body == self.bodies[k], self.points[k])

    def sample(self, particles):
        """(probes, len(COLUMNS)) values of every probe's point (collective; a probe
        whose point has left the grid reads NaN, and so do an FE node's stresses)."""
        for k, fixed in enumerate(self.fixed):
            if fixed:
                self.ids[k] = self.nearest(k, particles)
        values = np.zeros((len(self.ids), len(COLUMNS) + 1))
        on_nodes = np.array(self.on_nodes, bool)
        self.sample_particles(particles, np.where(on_nodes, -2, self.ids), values)
        if on_nodes.any():
            self.sample_nodes(np.where(on_nodes, self.ids, -2), values)
        values = self.world.sum(values)
        values[values[:, -1] == 0, :-1] = np.nan
        values[on_nodes, 6:] = np.nan
        return values[:, :-1]

    @staticmethod
    def sample_particles(particles, ids, values):
        for index in np.flatnonzero(np.isin(particles.id, ids[ids >= 0])):
            pressure, von_mises = stress_invariants(particles.stress[index:index + 1])
            for k in np.flatnonzero(ids == particles.id[index]):   # probes may share one
                values[k, :-1] = [*particles.x[index], *particles.v[index],
                                  *particles.stress[index], particles.eps_p[index],
                                  pressure[0], von_mises[0]]
                values[k, -1] = 1.0

    def sample_nodes(self, ids, values):
        """The FE nodes' position and velocity, from the rank that counts each node."""
        fem = self.elements
        for index in np.flatnonzero(np.isin(fem.node_id, ids[ids >= 0]) & fem.owned):
            for k in np.flatnonzero(ids == fem.node_id[index]):
                values[k, :6] = [*fem.x[index], *fem.v[index]]
                values[k, -1] = 1.0

    def state(self):
        return {name: int(i) for name, i, fixed in zip(self.names, self.ids, self.fixed)
                if not fixed}


def nearest_id(world, x, ids, candidates, point):
    """The id of the candidate (a bool mask over ``x`` and ``ids``) nearest ``point`` over
    all ranks (ties: the lower id), or -1 when there is none."""
    mine = np.flatnonzero(candidates)
    best = (np.inf, -1)
    if len(mine):
        d2 = ((x[mine] - np.asarray(point, np.float64)) ** 2).sum(axis=1)
        ids = ids[mine]
        k = np.lexsort((ids, d2))[0]
        best = (float(d2[k]), int(ids[k]))
    found = [b for b in world.allgather(best) if b[1] >= 0]
    return min(found)[1] if found else -1
