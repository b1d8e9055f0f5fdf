"""Probes (``output.probes``), sampled at every history row: position, velocity, stress,
eps_p, pressure and von Mises stress (rank 0 writes probe_NAME.csv, pmpm.io.probes).

* A probe on a particle body follows the particle nearest its point at the start
  (``fixed: false``, the default; LS-DYNA's tracer), or samples at every row the body's
  particle nearest the point then (``fixed: true``: a gauge at a place in space, Uintah's
  point extract without interpolation).
* ``id`` follows the particle (or FE node) of that id.
* ``region`` tags a group, the body's particles (or FE nodes) inside the box at the start
  (by their start position, which every particle keeps, split ones included), and
  samples their mass-weighted means (von Mises: the mean of theirs): LS-DYNA's nodal
  group or part averages, over material rather than a place.
* A probe on an FEM body does the same with the body's FE nodes: position and velocity;
  a node carries no stress, so the stress columns read NaN.

A point is known by its id, so it is found wherever it has migrated; the choice (the
smallest distance, then the lower id) and the sample (one rank holds the point, the
others add zeros) are the same on any number of ranks. A checkpoint keeps the ids of the
followed points, so a restart follows the same ones."""
import numpy as np

from ..io.derived import stress_invariants
from ..kernels import exact_sum
from .errors import SetupError
from .observe import exact_totals

#: The columns of a sample, after step and time.
COLUMNS = ("x", "y", "z", "vx", "vy", "vz", "sxx", "syy", "szz", "sxy", "syz", "szx",
           "eps_p", "pressure", "von_mises")


class Probes:
    def __init__(self, world, probes, particles, body_names, kept=None, elements=None,
                 exact=False):
        """``probes``: the case's output.probes; ``kept``: {name: id} of a checkpoint;
        ``elements``: the FEM bodies (pmpm.solver.fem_bodies.FemBodies) or None;
        ``exact``: sum over the ranks exactly (grid.exact_sums: the same bits on any
        rank count, pmpm.solver.observe.exact_totals)."""
        self.world, self.elements, self.exact = world, elements, exact
        self.names = [probe["name"] for probe in probes]
        self.bodies = [body_names.index(p["body"]) for p in probes]
        self.points = [None if p.get("point") is None else np.asarray(p["point"], np.float64)
                       for p in probes]
        self.regions = [region_box(p.get("region")) for p in probes]
        self.fixed = [bool(p.get("fixed", False)) for p in probes]
        self.on_nodes = [elements is not None and b in elements.body_indices
                         for b in self.bodies]
        kept = kept or {}
        self.ids = np.array([kept[p["name"]] if p["name"] in kept else
                             self.first_id(k, p, particles) for k, p in enumerate(probes)],
                            np.int64)
        self.given = [p.get("id") is not None or p.get("region") is not None
                      for p in probes]
        self.body_names = list(body_names)
        if not kept:
            self.check_targets(particles)

    def first_id(self, k, probe, particles):
        """Probe k's point at the start: the given id, the nearest to its point, or -1
        for a region (collective)."""
        if probe.get("id") is not None:
            return int(probe["id"])
        return -1 if self.regions[k] is not None else self.nearest(k, particles)

    def check_targets(self, particles):
        """Every probe given an id or a region samples something of its body at the
        start (collective): an id that is its body's, a region that holds some of it."""
        found = np.ones(len(self.names))
        for k in np.flatnonzero(self.given):
            x, ids, mine = self.points_of(k, particles)
            if self.regions[k] is not None:
                found[k] = np.count_nonzero(mine & in_box(x, self.regions[k]))
            else:
                found[k] = np.count_nonzero(mine & (ids == self.ids[k]))
        found = self.world.sum(found)
        missing = [f"output.probes[{k}].{'region' if self.regions[k] is not None else 'id'}"
                   f": {'selects no' if self.regions[k] is not None else 'is no id of a'} "
                   f"{'FE node' if self.on_nodes[k] else 'particle'} of body "
                   f"'{self.body_names[self.bodies[k]]}'"
                   for k in np.flatnonzero(found == 0)]
        if missing:
            raise SetupError(missing)

    def points_of(self, k, particles):
        """(start positions, ids, mask of probe k's body) of this rank's particles, or of
        the FE nodes it counts for a probe on an FEM body."""
        if self.on_nodes[k]:
            fem = self.elements
            return fem.x0, fem.node_id, (fem.node_body == self.bodies[k]) & fem.owned
        return particles.x0, particles.id, particles.body == self.bodies[k]

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
        grouped = np.array([box is not None for box in self.regions], bool)
        if self.exact:
            values = self.exact_sums(particles, values, grouped)
        else:
            for k in np.flatnonzero(grouped):
                self.sum_group(k, particles, values[k])
            values = self.world.sum(values)
        values[grouped] /= np.where(values[grouped, -1:] > 0, values[grouped, -1:], np.nan)
        values[values[:, -1] == 0, :-1] = np.nan
        values[on_nodes, 6:] = np.nan
        return values[:, :-1]

    def sum_group(self, k, particles, row):
        """Add this rank's part of region probe k to ``row``: the members' mass-weighted
        sums of the columns and, last, their mass."""
        m, columns = self.group_columns(k, particles)
        if len(m):
            row[:columns.shape[1]] += m @ columns
            row[-1] += m.sum()

    def group_columns(self, k, particles):
        """(mass (n,), columns (n, c)) of this rank's members of region probe k: the
        sample's columns (an FE node's first 6: position and velocity)."""
        x0, _, mine = self.points_of(k, particles)
        members = np.flatnonzero(mine & in_box(x0, self.regions[k]))
        if self.on_nodes[k]:
            fem = self.elements
            return fem.mass[members], np.hstack([fem.x[members], fem.v[members]])
        stress = particles.stress[members]
        pressure, von_mises = stress_invariants(stress)
        return particles.mass[members], np.hstack([
            particles.x[members], particles.v[members], stress,
            particles.eps_p[members][:, None], pressure[:, None], von_mises[:, None]])

    def exact_sums(self, particles, values, grouped):
        """``values`` (this rank's point samples) summed over the ranks exactly, with
        the region probes' mass-weighted sums, each member's ``m value`` a term
        (collective)."""
        width = values.shape[1]
        acc = exact_sum.zeros(values.size)
        held = np.flatnonzero(values[:, -1] > 0)
        for k in held:
            exact_sum.add_rows(acc, k * width, values[k:k + 1])
        for k in np.flatnonzero(grouped):
            m, columns = self.group_columns(k, particles)
            exact_sum.add_rows(acc, k * width, np.ascontiguousarray(m[:, None] * columns))
            exact_sum.add_terms(acc, k * width + width - 1, np.ascontiguousarray(m))
        return exact_totals(self.world, [acc])[0].reshape(values.shape)

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
        return {name: int(i) for name, i, fixed, box in
                zip(self.names, self.ids, self.fixed, self.regions)
                if not fixed and box is None}


def region_box(region):
    """(lower, upper) corners of a probe's region, or None."""
    if region is None:
        return None
    return np.asarray(region["min"], np.float64), np.asarray(region["max"], np.float64)


def in_box(x, box):
    """Mask of the rows of ``x`` inside ``box`` (its faces included)."""
    lo, hi = box
    return np.all((x >= lo) & (x <= hi), axis=1)


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
