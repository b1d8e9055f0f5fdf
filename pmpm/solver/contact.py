"""Multi-velocity grid contact in the step (seed 001 Sec. 4): the pair rules from the
case, and the phases that build, exchange and use the per-body fields at contact nodes.
The node loops are in ``pmpm.kernels.contact``."""
import numpy as np

from ..comm import sum_shared_planes
from ..comm.exchange import or_shared_planes
from ..kernels import contact as kc
from ..kernels import tied
from ..materials import layout

MAX_BODIES = 62          # one bit per body in the int64 node masks


class ContactRules:
    """Per pair of bodies: the Coulomb coefficient and whose normal both bodies use.

    Attributes
    ----------
    method : int    0 (none: one shared field), 1 or 2 (seed 001 Secs. 3.1, 3.2)
    friction : (nb, nb) float64
    master : (nb, nb) int64   -1: average of the two normals (Eq. 10); else a body index
    separation : (nb, nb) float64   cells; contact needs the two bodies' mean positions at
        a node at most this far apart along the normal (inf: no check, seed 001 Sec. 2.2)
    """

    def __init__(self, contact, bodies):
        names = bodies.names
        nb = len(names)
        self.method = int(contact.get("method", 0))
        self.skip_separating = self.method == 2 and bool(contact.get("skip_separating"))
        if self.method and nb > MAX_BODIES:
            raise ValueError(f"contact: at most {MAX_BODIES} bodies, got {nb}")
        self.friction = np.full((nb, nb), float(contact.get("friction", 0.0)))
        self.separation = np.full((nb, nb), _limit(contact.get("separation")))
        self.master = np.full((nb, nb), -1, np.int64)
        default = contact.get("normal", "average")
        stiffness = [_stiffness(bodies, b) for b in range(nb)]
        for a in range(nb):
            for b in range(nb):
                if a != b:
                    self.master[a, b] = _master(default, a, b, names, stiffness)
        for pair in contact.get("pairs", []):
            a, b = (names.index(name) for name in pair["bodies"])
            mu = float(pair.get("friction", contact.get("friction", 0.0)))
            self.friction[a, b] = self.friction[b, a] = mu
            if "separation" in pair:                # none here: no check for this pair
                self.separation[a, b] = self.separation[b, a] = _limit(pair["separation"])
            rule = pair.get("normal", default)
            self.master[a, b] = self.master[b, a] = _master(rule, a, b, names, stiffness)

    @property
    def active(self):
        return self.method > 0


def _limit(separation):
    return np.inf if separation is None else float(separation)


def _stiffness(bodies, b):
    """Wave modulus K + 4G/3 (infinite for rigid bodies), to find the stiffer body."""
    if bodies.rigid[b]:
        return np.inf
    prm = bodies.params[b]
    return prm[layout.K] + 4.0 * prm[layout.G] / 3.0


def _master(rule, a, b, names, stiffness):
    if rule == "average":
        return -1
    if rule == "stiffer":
        if stiffness[a] == stiffness[b]:
            return -1                      # equally stiff: the average is the fair choice
        return a if stiffness[a] > stiffness[b] else b
    return names.index(rule)


class ContactFields:
    """The per-body nodal fields of one step at the contact nodes of this rank's block.

    Slots are numbered in local node order and every rank finds the same contact nodes on
    a shared plane (the body masks are OR-ed there first), so a plane's slots are one
    contiguous range with the same length on both neighbours: its per-body values are
    summed with one message per neighbour, like the shared field.
    """

    def __init__(self, rules, world, work, m_tiny):
        self.rules, self.world, self.work, self.m_tiny = rules, world, work, m_tiny
        self.slot_of = np.full(0, -1, np.int64)
        self.slot_nodes = np.zeros(0, np.int64)
        self.empty = np.zeros((0, 1, 6))

    def find_contact_nodes(self, particles, grid, block, level_of, want, ties):
        """Nodes that particles of two or more bodies reach, tied slaves left out (they
        follow their masters)."""
        mask = np.zeros(block.n_nodes, np.int64)
        kc.body_masks(particles.x, particles.body, grid.origin, grid.inv_h, block.lo,
                      block.strides, mask, level_of, want)
        or_shared_planes(self.world, block.shared_planes, block.as_planes(mask))
        if ties is not None:
            tied.clear_slave_slots(ties.slaves, ties.count, mask)
        self.slot_of = np.empty(block.n_nodes, np.int64)
        self.slot_nodes = kc.number_contact_nodes(mask, self.slot_of)
        self.plane_slots = self._plane_slot_ranges(block)

    def _plane_slot_ranges(self, block):
        per_plane = block.n_nodes // max(int(block.shape[block.slab_axis]), 1)
        ranges = {}
        for _, index in block.shared_planes:
            first, last = index * per_plane, (index + 1) * per_plane
            ranges[index] = (int(np.searchsorted(self.slot_nodes, first)),
                             int(np.searchsorted(self.slot_nodes, last)))
        return ranges

    def sum_on_shared_planes(self, block, array):
        views = {index: array[a:b] for index, (a, b) in self.plane_slots.items()}
        sum_shared_planes(self.world, block.shared_planes, views)

    def slot_array(self, name, width, n_bodies, zero=True):
        rows = len(self.slot_nodes)
        flat = (self.work.zeros if zero else self.work.empty)(name, rows, width * n_bodies)
        return flat.reshape(rows, n_bodies, width)

    def map_particles(self, particles, grid, block, n_bodies, level_of, want, ties=None):
        """Per-body mass, momentum, mass gradient and mean offset at the contact nodes of
        one grid level (``grid``: a ``pmpm.grid.Level``) from its particles
        (``level_of == want``)."""
        p = particles
        self.find_contact_nodes(p, grid, block, level_of, want, ties)
        self.cnodal = self.slot_array("cnodal", kc.CNODAL, n_bodies)
        kc.contact_particles_to_grid(p.x, p.v, p.mass, p.body, grid.origin, grid.inv_h,
                                     block.lo, block.strides, self.slot_of, self.cnodal,
                                     level_of, want)
        self.sum_on_shared_planes(block, self.cnodal)

    def start_velocities(self, gvel, bodies, grid, block):
        nb = self.cnodal.shape[1]
        self.cvel = self.slot_array("cvel", 3, nb, zero=False)
        self.cnorm = self.slot_array("cnorm", 3, nb, zero=False)
        kc.contact_start(self.cnodal, self.slot_nodes, gvel, self.rules.master,
                         self.rules.separation, bodies.rigid, self.rules.method, self.m_tiny,
                         block.shape, block.lo, block.strides, grid.n_cells, grid.boundary,
                         self.cvel, self.cnorm)
        self.cforce = self.slot_array("cforce", 3, nb)

    def end_velocities(self, gvel, gnew, bodies, dt, grid, block):
        self.sum_on_shared_planes(block, self.cforce)
        self.cnew = self.slot_array("cnew", kc.CNEW, self.cnodal.shape[1], zero=False)
        kc.contact_end(self.cnodal, self.cvel, self.cnorm, self.cforce, self.slot_nodes, gvel,
                       gnew, self.rules.friction, self.rules.separation, bodies.rigid,
                       self.rules.skip_separating, dt, self.m_tiny, block.shape, block.lo,
                       block.strides, grid.n_cells, grid.boundary, self.cnew)

    @property
    def n_slots(self):
        return len(self.slot_nodes)
