"""Multi-velocity grid contact in the step (seed 001 Sec. 4): the pair rules from the
case, and the coupling that builds, exchanges and uses the per-body fields at contact
nodes. The node loops are in ``pmpm.kernels.contact``."""
import numpy as np

from ..comm import sum_shared_planes
from ..comm.exchange import (max_shared_planes, or_shared_planes,
                             sum_shared_planes_in_layer_order)
from ..kernels import contact as kc
from ..kernels.boundary import column_kinds, mirror_extents, mirror_masks
from ..kernels import tied
from ..kernels.records import ContactSlots, ContactView, PairRules
from ..materials import layout
from .couplings import Coupling, kept_copy
from .levels import PART
from .workspace import Workspace

#: how the contact slots' arrays reflect across planes of symmetry (kernels.boundary)
CNODAL_KINDS = column_kinds(kc.CNODAL, velocity=(1,), geometric=(4, 7))
CFORCE_KINDS = column_kinds(3, velocity=(0,))
VOLUME_KINDS = column_kinds(1)
MAX_BODIES = 62          # one bit per body in the int64 node masks
#: ``ContactRules.coupling`` codes of a pair of an FEM body and another body
NO_COUPLING, GRID_COUPLING, SURFACE_COUPLING = 0, 1, 2
COUPLING_CODES = {"grid": GRID_COUPLING, "surface": SURFACE_COUPLING}


class ContactRules:
    """Per pair of bodies: the Coulomb coefficient and whose normal both bodies use.

    Attributes
    ----------
    method : int    0 (none: one shared field), 1 or 2 (seed 001 Secs. 3.1, 3.2)
    friction : (nb, nb) float64
    master : (nb, nb) int64   -1: average of the two normals (Eq. 10); else a body index
    separation : (nb, nb) float64   cells; contact needs the two bodies' mean positions at
        a node at most this far apart along the normal (inf: no check, seed 001 Sec. 2.2)
    release : (nb, nb) float64   cells; the release rule: no contact where the surfaces
        of the two bodies at a node, from their particles' positions, are more than this
        far apart (inf: no release rule, seed 001's methods unchanged)
    volume_gap : bool   the release rule measures the gap from the bodies' shares of the
        node's hat (``contact.gap: volume``) rather than their particles' reach
    coupling : (nb, nb) int64   for a pair with an FEM body, how they meet: a particle
        body GRID_COUPLING (CFEMP) or SURFACE_COUPLING (ICFEMP); another FEM body
        SURFACE_COUPLING (node-to-surface contact, pmpm.solver.node_contact) or
        GRID_COUPLING (both bodies' FE nodes in the grid contact: AFEMP, method 1);
        NO_COUPLING for every pair of particle bodies
    """

    def __init__(self, contact, bodies, fem=None):
        """``contact``: a ``pmpm.case.ContactConfig``; ``bodies``: a BodyTable; ``fem``:
        per body, whether it is an FEM body (None: none is)."""
        names = bodies.names
        nb = len(names)
        self.method = contact.method
        self.skip_separating = skip_code(contact) if self.method == 2 else kc.SKIP_NONE
        if self.method and nb > MAX_BODIES:
            raise ValueError(f"contact: at most {MAX_BODIES} bodies, got {nb}")
        self.friction = np.full((nb, nb), float(contact.friction))
        self.separation = np.full((nb, nb), _limit(contact.separation))
        self.release = np.full((nb, nb), _limit(contact.release))
        self.volume_gap = contact.gap == "volume"
        self.master = np.full((nb, nb), -1, np.int64)
        default = contact.normal
        stiffness = [_stiffness(bodies, b) for b in range(nb)]
        for a in range(nb):
            for b in range(nb):
                if a != b:
                    self.master[a, b] = _master(default, a, b, names, stiffness)
        pairs = listed_pairs(contact.pairs, names, bodies.converted_into)
        for a, b, pair, normal in pairs:         # resolved: what a pair leaves out is
            self.friction[a, b] = self.friction[b, a] = float(pair.friction)  # the
            self.separation[a, b] = self.separation[b, a] = _limit(pair.separation)
            self.release[a, b] = self.release[b, a] = _limit(pair.release)   # section's
            self.master[a, b] = self.master[b, a] = _master(normal, a, b, names, stiffness)
        self.coupling = _couplings(contact, pairs, np.zeros(nb, bool) if fem is None
                                   else np.asarray(fem, bool), bodies.converted_into)

    @property
    def active(self):
        """Whether grid contact runs: a method and a pair of bodies to apply it to."""
        return self.method > 0 and self.friction.shape[0] > 1

    @property
    def releases(self):
        """True when some pair has the release rule."""
        return bool(np.isfinite(self.release).any())

    def record(self):
        return PairRules(self.master, self.friction, self.separation)


def listed_pairs(pairs, names, converted_into):
    """(a, b, pair, normal) for each pair of ``contact.pairs`` and, where an FEM body of
    it converts into a particle body of its own (``converted_into`` >= 0,
    pmpm.case.config.converted_bodies), for that body in its place: what the pair says
    of the elements holds for the particles they become (``normal`` naming the body that
    stands in)."""
    out = []
    for pair in pairs:
        a, b = (names.index(name) for name in pair.bodies)
        for x in (a, converted_into[a]):
            for y in (b, converted_into[b]):
                if x < 0 or y < 0:
                    continue
                normal = {names[a]: names[x], names[b]: names[y]}.get(pair.normal,
                                                                      pair.normal)
                out.append((int(x), int(y), pair, normal))
    return out


def _couplings(contact, pairs, fem, converted_into):
    """The coupling code of every pair with an FEM body (see ``ContactRules.coupling``):
    its coupling, or the section's (two FEM bodies on the grid need method 1: the case
    check refuses the others); an FEM body and the particle body its elements convert
    into meet on the grid."""
    mixed = fem[:, None] != fem[None, :]
    both = fem[:, None] & fem[None, :] & ~np.eye(len(fem), dtype=bool)
    coupling = np.where(mixed | both, COUPLING_CODES[contact.coupling], NO_COUPLING)
    for a, b, pair, _ in pairs:
        if mixed[a, b] or both[a, b]:
            coupling[a, b] = coupling[b, a] = COUPLING_CODES[pair.coupling]
    for a, b in enumerate(converted_into):
        if b >= 0:
            coupling[a, b] = coupling[b, a] = GRID_COUPLING
    return coupling.astype(np.int64)


def skip_code(contact):
    """``contact.skip_separating`` as the kernel's code: false none, true every pair,
    auto the frictionless pairs (pmpm.kernels.contact.contact_end)."""
    if contact.skip_separating is True:
        return kc.SKIP_ALL
    return kc.SKIP_FRICTIONLESS if contact.skip_separating == "auto" else kc.SKIP_NONE


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


def start_shares(config):
    """Per body, the share of method 2's start correction (Eq. 25) that reaches its
    velocities: 1 under APIC (the particles take the new nodal velocity), ``time.pic``
    under FLIP (the acceleration alone, blended with that share of PIC), 0 for an FEM
    body's nodes (they take the acceleration)."""
    particles = 1.0 if config.time.transfer == "apic" else float(config.time.pic)
    return [0.0 if b.is_fem else particles for b in config.bodies]


class GridContact(Coupling):
    """Multi-velocity grid contact as a coupling of the step: per-body fields at the
    contact nodes of every level, the start-of-step correction of method 2 and the
    end-of-step contact forces (seed 001 Secs. 3-4)."""

    def __init__(self, rules, world, bodies, m_tiny, n_levels, start_share):
        self.rules, self.bodies, self.m_tiny = rules, bodies, m_tiny
        # the share of method 2's start correction that reaches each body's velocities,
        # counted in Coulomb's limit under the release rule (kc.contact_end)
        self.start_share = (np.asarray(start_share, np.float64) if rules.releases
                            else np.zeros(len(bodies.names)))
        self.pairs = rules.record()
        self.fields = [ContactFields(world) for _ in range(n_levels)]

    def after_mass_sum(self, grids, kinds):
        nb = len(self.bodies.names)
        for s in grids:
            self.fields[s.index].map_points(kinds, s, nb, self.rules.releases,
                                            self.rules.volume_gap)

    def after_velocities(self, grids):
        for s in grids:
            f = self.fields[s.index]
            nb = f.cnodal.shape[1]
            f.cvel = f.slot_array("cvel", 3, nb, zero=False)
            f.cnorm = f.slot_array("cnorm", 3, nb, zero=False)
            kc.contact_start(f.slots(), s.gvel, self.pairs, self.bodies.grid_rigid,
                             self.rules.method, self.m_tiny, s.nodes,
                             kc.FLAT if self.rules.releases else 0.0)
            if self.rules.releases:
                kc.release_open_gaps(f.slots(), f.cext, f.cvol, self.rules.release,
                                     s.geometry.half_width, self.m_tiny, s.nodes)
            if self.rules.method == 2 and nb > 2:
                kc.balance_start(f.slots(), self.bodies.grid_rigid, self.m_tiny, s.nodes)
            f.cforce = f.slot_array("cforce", 3, nb)
            s.kept.pop("cforce", None)         # until a layered force scatter keeps some

    def after_integrate(self, grids, dt):
        for s in grids:
            f = self.fields[s.index]
            f.sum_on_shared_planes(s.block, f.cforce, s, "cforce")
            s.reflect(f.cforce, CFORCE_KINDS, f.slot_of)
            f.cnew = f.slot_array("cnew", kc.CNEW, f.cnodal.shape[1], zero=False)
            kc.contact_end(f.slots(), s.gvel, s.gnew, self.pairs, self.bodies.grid_rigid,
                           self.rules.skip_separating, dt, self.m_tiny, s.nodes,
                           self.start_share)

    def view(self, state):
        return self.fields[state.index].view()

    def n_slots(self):
        return sum(f.n_slots for f in self.fields)


class ContactFields:
    """The per-body nodal fields of one step at the contact nodes of one level's block.

    Slots are numbered in local node order and every rank finds the same contact nodes on
    a shared plane (the body masks are OR-ed there first), so a plane's slots are one
    contiguous range with the same length on both neighbours: its per-body values are
    summed with one message per neighbour, like the shared field.
    """

    def __init__(self, world):
        self.world = world
        self.work = Workspace()
        self.slot_of = np.full(0, -1, np.int64)
        self.slot_nodes = np.zeros(0, np.int64)
        self.cnodal = np.zeros((0, 1, kc.CNODAL))
        self.cvel = self.cnorm = self.cforce = np.zeros((0, 1, 3))
        self.cnew = np.zeros((0, 1, kc.CNEW))
        self.cext = np.zeros((0, 1, kc.CEXT))
        self.cvol = np.zeros((0, 1))
        self.real_mass = None

    def find_contact_nodes(self, kinds, state):
        """Nodes that points of two or more bodies reach, tied slaves left out (they
        follow their masters)."""
        block = state.block
        mask = self.work.empty("mask", block.n_nodes, 1, np.int64)[:, 0]  # kept: a fresh
        mask.fill(0)        # array each step was page-faulted in (128 KiB mmap threshold)
        for kind in kinds:
            kind.mark_bodies(state, mask)
        or_shared_planes(self.world, block.shared_planes, block.as_planes(mask))
        mirror_masks(mask, state.mirror)
        for ties in state.slave_ties:
            tied.clear_slave_slots(ties, mask)
        self.slot_of = self.work.empty("slot_of", block.n_nodes, 1, np.int64)[:, 0]
        self.slot_nodes = kc.number_contact_nodes(mask, self.slot_of)
        self.plane_slots = self._plane_slot_ranges(block)
        plane = block.strides[block.slab_axis]
        #: the first slot of each node plane, for layer-ordered scatters into slots
        state.slot_starts = np.searchsorted(
            self.slot_nodes, np.arange(block.shape[block.slab_axis] + 1) * plane)

    def _plane_slot_ranges(self, block):
        per_plane = block.n_nodes // max(int(block.shape[block.slab_axis]), 1)
        ranges = {}
        for _, span in block.shared_planes:
            first, last = span[0] * per_plane, span[1] * per_plane
            ranges[span] = (int(np.searchsorted(self.slot_nodes, first)),
                            int(np.searchsorted(self.slot_nodes, last)))
        return ranges

    def sum_on_shared_planes(self, block, array, state=None, name=None):
        """Sum the slot array on the shared planes; in layer order (to the bit of one
        rank) where ``state`` holds the kept layers of ``name``'s layered scatter, and
        a second kind's part of it on its own, then added (``LevelState.part``)."""
        self.sum_slots(block, array, state, name)
        part = state.parts.pop(name, None) if state is not None else None
        if part is not None:
            self.sum_slots(block, part, state, name + PART)
            array += part

    def sum_slots(self, block, array, state, name):
        views = {span: array[a:b] for span, (a, b) in self.plane_slots.items()}
        if state is not None and state.exact and name in state.kept:
            sum_shared_planes_in_layer_order(self.world, block.shared_planes, views,
                                             state.kept_rows(name, array.shape[1:]))
        else:
            sum_shared_planes(self.world, block.shared_planes, views)

    def slot_array(self, name, width, n_bodies, zero=True):
        rows = len(self.slot_nodes)
        flat = (self.work.zeros if zero else self.work.empty)(name, rows, width * n_bodies)
        return flat.reshape(rows, n_bodies, width)

    def map_points(self, kinds, state, n_bodies, extents=False, volumes=False):
        """Per-body mass, momentum, mass gradient and mean offset at the contact nodes of
        one grid level from its points; with ``extents`` also the farthest reach of each
        body's particles (``cext``, for the release rule), and with ``volumes`` their
        weighted volumes instead (``cvol``, for the release rule's volume gap)."""
        self.find_contact_nodes(kinds, state)
        self.cnodal = self.slot_array("cnodal", kc.CNODAL, n_bodies)
        state.kept.pop("cnodal", None)
        for kind in kinds:
            kind.scatter_contact(state, self.slot_of, self.cnodal)
        self.sum_on_shared_planes(state.block, self.cnodal, state, "cnodal")
        # what each body's own particles put on the nodes (the force histories)
        self.real_mass = kept_copy(self.real_mass, self.cnodal[:, :, 0])
        state.reflect(self.cnodal, CNODAL_KINDS, self.slot_of)
        if extents and volumes:
            self.cvol = self.slot_array("cvol", 1, n_bodies)[:, :, 0]
            state.kept.pop("cvol", None)
            for kind in kinds:
                kind.scatter_volumes(state, self.slot_of, self.cvol)
            self.sum_on_shared_planes(state.block, self.cvol, state, "cvol")
            state.reflect(self.cvol, VOLUME_KINDS, self.slot_of)
        elif extents:
            self.cext = self.slot_array("cext", kc.CEXT, n_bodies, zero=False)
            self.cext.fill(-np.inf)
            for kind in kinds:
                kind.scatter_extents(state, self.slot_of, self.cext)
            views = {span: self.cext[a:b] for span, (a, b) in self.plane_slots.items()}
            max_shared_planes(self.world, state.block.shared_planes, views)
            if len(state.mirror):
                mirror_extents(self.cext, state.mirror, self.slot_of)

    def slots(self):
        return ContactSlots(self.cnodal, self.slot_nodes, self.cvel, self.cnorm, self.cforce,
                            self.cnew)

    def view(self):
        return ContactView(self.slot_of, self.cvel, self.cforce, self.cnew)

    @property
    def n_slots(self):
        return len(self.slot_nodes)
