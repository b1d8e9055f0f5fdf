"""Grid coupling of FEM bodies to particle bodies (CFEMP, seed 004 Sec. 2.4, Eqs. 22-32;
``shared/seeds/004_NOTES.md`` Secs. 1.2, 1.5 and 4).

The FE nodes of every FEM body that meets a particle body on the grid
(``ContactRules.coupling`` = GRID_COUPLING) take part in the coarse grid's phases as if
they were particles of their body, through :class:`FemGridNodes`, a body kind of the
step beside the particles. Only the nodes within NEAR_CELLS cells (and twice the widest
particle's half-spacing) of the box of a body they meet on the grid do (the seed's
local multi-mesh contact): a node farther away
shares no grid node with that body, so on the grid it met nobody and took no correction.
The rolling sphere's plate maps 2,875 of its 29,997 nodes, and the run moves to the same
bits as with every node mapped, at 0.74 times the step's cost
(docs/performance-notes.md):

* map to the grid: they scatter mass and momentum m_K v_K (v at the step's start) into
  the shared field and, at contact nodes, mass, momentum, mass gradient (the normal,
  Eq. 23) and extents into their body's field, with the particle kernels;
* forces: the mesh has already advanced the nodes (``FemBodies.stress_and_forces`` and
  ``integrate``: v_K -> v̄_K = v_K + dt f_K / m_K, its own conditions applied), so each
  node scatters f̃_K = m_K (v̄_K - v_K) / dt: the body's trial momentum at a grid node is
  sum_K N_IK m_K v̄_K (Eq. 26);
* grid to points: after the grid contact's end-of-step correction
  (``GridContact.after_integrate``, Eqs. 28-32 as pmpm's contact kernels do them) each
  node takes dv_K = sum_I N_IK dt f_I^c / m_I of its body (FLIP; momentum is conserved
  since sum_K N_IK m_K = m_I), then its constraints and the grid faces again; the nodes
  then move (``FemBodies.move``).

Method 2's start-of-step correction changes the velocities the particles' stresses use;
the elements' stresses use the FE nodes' own velocities (the mesh is advanced before the
grid's forces, from the nodes alone). Rigid FEM bodies go into the grid's rigid slots,
like rigid particle bodies: they impose their velocity and take no correction; a free
rigid body (``rigid.free``) joins the contact with its nodes' masses and takes the sum of
their corrections (pmpm.solver.rigid_motion).

Over MPI the nodes are copies on every rank holding one of their elements. Each node is
mapped once, by the rank whose slab holds it (the rule of particles, so that rank's
block covers its shape functions: the blocks' cell ranges include the nodes, see
:meth:`FemGridNodes.spans`); when no rank holding the node owns that slab, the node's
lowest holder lends it to that rank for the step (one packed sparse exchange,
pmpm.comm.sparse, at the map, one for the forces, one back with the velocity change, only
in steps where some rank lends). The
velocity change is then summed over the holders (one rank's is non-zero), so every copy
takes the same.

Shape functions: an FE node is a point of no extent, and with the trilinear hats the
gradient of a node's weight jumps where the point sits on that node. A mesh whose nodes
lie on grid planes (elements = cells on the grid lines) then gets mass gradients whose
tangential parts flip with every rounding-error move of its nodes, and the normals are
garbage: a block on such a plate stuck (tests/cases/fem_grid_sliding.yaml with
``linear``: a = -0.14 instead of 3.27 m/s^2; the plate moved off the grid planes by a
quarter cell: 2.93). With ``gimp`` (the node has the half-width of its body) or
``bspline`` the gradients are continuous and the same plate gives 3.25 (gimp, method 1).

FE nodes map to the coarse grid only: a refined window over a grid-coupled FEM body is
refused at set-up, as are MUSL, contact method 2 under APIC or a PIC blend (the nodes
cannot take the start correction the particles take: momentum would not be conserved),
and an FEM body that meets some particle bodies on the grid and others by surface
contact.
"""
import numpy as np

from ..comm.shared_nodes import sum_shared_rows
from ..comm.sparse import exchange_arrays
from ..kernels import contact as kc
from ..materials import layout
from ..kernels import fem_grid as kf
from ..kernels import mpm, tied
from ..kernels.records import PointState
from .contact import GRID_COUPLING, SURFACE_COUPLING, GridContact
from .contact_halo import body_boxes, grown
from .errors import SetupError
from .levels import PART
from .kinds import BodyKind
from .workspace import Workspace


#: how near (in cells) an FE node must come to the box of a body its body meets on the
#: grid to map to the grid, beyond twice the widest particle's half-spacing: a node and
#: a point share a grid node only within their two stencils' reach (a cell and a
#: half-width each), with a margin
NEAR_CELLS = 4.0


class FemGridNodes(BodyKind):
    """The FE nodes of the grid-coupled FEM bodies as points of the coarse grid.

    Parameters
    ----------
    elements : solver.fem_bodies.FemBodies
    contact : solver.contact.GridContact   (its per-body fields)
    decomposition : solver.decomposition.Decomposition   (the current slabs)
    grid : grid.CoarseGrid
    bodies : solver.bodies.BodyTable
    coupled : (nb,) bool   the FEM bodies on the grid
    m_tiny : float
    """

    label = "FE node"
    on_grid = True

    def __init__(self, elements, contact, decomposition, grid, bodies, coupled, m_tiny,
                 points=None, meets=None):
        self.elements, self.contact = elements, contact
        self.decomposition, self.grid = decomposition, grid
        self.rigid, self.coupled, self.m_tiny = bodies.grid_rigid, np.asarray(coupled), m_tiny
        #: the particle bodies' kind, and which bodies meet on the grid ([a, b]): an FE
        #: node maps to the grid only near a body it meets there (:meth:`near_others`)
        self.points, self.meets = points, meets
        self.world = elements.world
        self.work = Workspace()
        self.fault = None
        self.pts = self.empty_points()
        self.mine = self.lent = np.zeros(0, np.int64)
        #: the points' node ids and, with layer-ordered sums, their canonical order
        self.ids = self.order = np.zeros(0, np.int64)
        self.lent_to, self.guest_counts, self.lending = np.zeros(0, np.int64), [], False

    @staticmethod
    def empty_points():
        return PointState(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0),
                          np.zeros(0, np.int32), np.zeros(0, np.int32))

    # -- which rank maps which node ------------------------------------------------------
    def positions(self):
        """The coupled nodes (local indices) that may meet another body on the grid
        (:meth:`near_others`) and their positions held inside the grid box (a node on a
        face may lie a rounding error beyond it; the kernels need its cell). Collective."""
        e = self.elements
        nodes = np.flatnonzero(self.near_others())
        g = self.grid
        x = np.clip(e.x[nodes], g.origin, g.upper - 1e-9 * g.h)
        return nodes, x

    def near_others(self):
        """(FE nodes,) bool: the coupled nodes within NEAR_CELLS cells (and twice the widest
        particle's half-spacing) of the box of a body their body meets on the grid (over
        all ranks: the same nodes on any rank count). A node farther than that shares no
        grid node with that body's points, so on the grid it met nobody and took no
        correction: the seed's local multi-mesh contact maps only the near ones. One
        reduction; collective."""
        e = self.elements
        if self.meets is None:
            return self.coupled[e.node_body]
        nb = len(self.coupled)
        boxes = body_boxes(e.x, e.x, e.node_body, nb)
        if self.points is not None:
            p = self.points.particles
            more = body_boxes(p.x, p.x, p.body, nb)
            boxes[:, 0] = np.minimum(boxes[:, 0], more[:, 0])
            boxes[:, 1] = np.maximum(boxes[:, 1], more[:, 1])
        # one reduction: the boxes' lows, minus their highs and minus the widest particle
        wide = self.widest_particle()
        least = self.world.min(np.concatenate([boxes[:, 0].ravel(), -boxes[:, 1].ravel(),
                                               [-wide]]))
        lo, hi = least[:3 * nb].reshape(nb, 3), -least[3 * nb:6 * nb].reshape(nb, 3)
        reach = grown(np.stack([lo, hi], axis=1), NEAR_CELLS * self.grid.h - 2.0 * least[-1])
        near = self.work.empty("near", len(e.x), 1, np.bool_)[:, 0]
        kf.near_coupled_nodes(e.x, e.node_body, self.coupled, self.meets, reach, near)
        return near

    def widest_particle(self):
        """This rank's largest particle half-spacing (converted elements' particles can be
        wider than a cell, and their stencils reach that much farther)."""
        vol0 = self.points.particles.vol0 if self.points is not None else np.zeros(0)
        return 0.5 * float(np.cbrt(vol0.max(initial=0.0)))

    def mappers(self, x):
        """The rank whose slab holds each position (the kernels' cell rule)."""
        g, slabs = self.grid, self.decomposition.slabs
        owner = np.empty(len(x), np.int64)
        mpm.classify_particles(x, g.origin, 1.0 / g.h, g.n_cells, slabs.axis, slabs.bounds,
                               self.world.rank, owner)
        return owner

    def gather(self):
        """This step's points: the coupled nodes this rank maps (their slab is its own),
        then the nodes lent to it. Remembers the velocities of the step's start."""
        e, rank = self.elements, self.world.rank
        nodes, x = self.positions()
        mapper = np.full(len(e.x), -1, np.int64)
        mapper[nodes] = self.mappers(x)
        held = mapper == rank
        for other, idx in e.partners:
            held[idx] |= mapper[idx] == other
        clipped = np.zeros_like(e.x)
        clipped[nodes] = x
        self.mine = np.flatnonzero(mapper == rank)
        self.lent = np.flatnonzero((mapper >= 0) & e.owned & ~held)
        self.lent_to = mapper[self.lent]
        self.lending = bool(self.world.any(len(self.lent) > 0))
        guests = self.receive_guests(clipped) if self.lending else []
        self.v_start = self.work.empty("v_start", len(e.v), 3)
        self.v_start[:] = e.v
        self.pts = self.point_state(clipped, guests)

    def receive_guests(self, clipped):
        """Send the lent nodes to the ranks that map them; [(x, v, m, body)] by sender."""
        e = self.elements
        packages = []
        for r in range(self.world.size):
            idx = self.lent[self.lent_to == r]
            packages.append((clipped[idx], e.v[idx], e.mass[idx], e.node_body[idx],
                             e.node_id[idx]))
        received = exchange_arrays(self.world, packages)
        self.guest_counts = [len(part[2]) for part in received]
        return received

    def point_state(self, clipped, guests):
        e, mine = self.elements, self.mine
        parts = [(clipped[mine], e.v[mine], e.mass[mine], e.node_body[mine],
                  e.node_id[mine])] + list(guests)
        x, v, m, b, ids = (np.concatenate([p[i] for p in parts]) for i in range(5))
        self.ids = ids.astype(np.int64)
        return PointState(np.ascontiguousarray(x), np.ascontiguousarray(v), m,
                          b.astype(np.int32), np.zeros(len(m), np.int32))

    def swap_rows(self, rows):
        """Send ``rows`` (per local node, (n, 3)) of the lent nodes to their mappers;
        returns what the guests' lenders sent, in guest order."""
        packages = [(rows[self.lent[self.lent_to == r]],) for r in range(self.world.size)]
        received = exchange_arrays(self.world, packages)
        return np.concatenate([part[0] for part in received]).reshape(-1, 3)

    # -- phases of the step ------------------------------------------------------------
    def scatter_mass_momentum(self, state):
        if state.index == 0:
            self.gather()
        if self.layered(state):
            self.order = self.canonical_order(state)
            nodal = state.part("nodal", state.nodal.shape)
            mpm.particles_to_grid(self.pts, self.rigid, state.geometry, nodal, 0, None,
                                  state.layer_sums("nodal" + PART, nodal.shape[1],
                                                   self.order))
            return
        mpm.particles_to_grid(self.pts, self.rigid, state.geometry, state.nodal, state.index,
                              None, None)   # no affine matrices, no layers: the warm-up's
                                            # signature

    @staticmethod
    def layered(state):
        """Whether this kind's sums on ``state`` are layer-ordered parts (the nodes map
        to the coarse grid only)."""
        return state.exact and state.index == 0

    def canonical_order(self, state):
        """The points by (coarse cell with the slab axis slowest, node id), the order of
        the particles' layered scatters (``pmpm.kernels.layered``): a rank's nodes of a
        cell layer are the one-rank order's, lent ones included."""
        lv, pts = state.level, self.pts
        cells = mpm.slab_cell_keys(pts.x, lv.origin, lv.inv_h, lv.n_cells,
                                   state.block.slab_axis)
        return np.lexsort((self.ids, cells)).astype(np.int64)

    def mark_occupied(self, coarse, occupied):
        g = coarse.geometry
        tied.mark_occupied(self.pts.x, self.pts.level, g.origin, g.inv_h, g.lo, g.strides,
                           occupied)

    def mark_bodies(self, state, mask):
        kc.body_masks(self.pts, state.geometry, mask, state.index)

    def scatter_contact(self, state, slot_of, cnodal):
        if self.layered(state):
            part = state.part("cnodal", cnodal.shape)
            kc.contact_particles_to_grid(
                self.pts, state.geometry, slot_of, part, 0, None,
                state.layer_sums("cnodal" + PART, part.shape[1] * part.shape[2], self.order,
                                 state.slot_starts))
            return
        kc.contact_particles_to_grid(self.pts, state.geometry, slot_of, cnodal, state.index,
                                     None, None)

    def scatter_extents(self, state, slot_of, cext):
        kc.contact_extents(self.pts, state.geometry, slot_of, cext, state.index)

    def scatter_volumes(self, state, slot_of, cvol):
        """The nodes' lumped volumes (mass over the body's initial density) for the volume
        gap: the node sampling of the mesh's material, as hats sample particles."""
        rho0 = self.elements.table.params[self.pts.body, layout.RHO0]
        if self.layered(state):
            part = state.part("cvol", cvol.shape)
            kc.contact_volumes(self.pts, self.pts.mass / rho0, state.geometry, slot_of, part,
                               0, state.layer_sums("cvol" + PART, part.shape[1], self.order,
                                                   state.slot_starts))
            return
        kc.contact_volumes(self.pts, self.pts.mass / rho0, state.geometry, slot_of, cvol,
                           state.index, None)

    def stress_and_forces(self, state, dt, contact):
        """The nodes' forces f̃_K = m_K (v̄_K - v_K) / dt to the grid and their body's
        contact field (the mesh has advanced them already). No stress, no speed of its
        own (the mesh reports its own)."""
        if state.index != 0:
            return 0.0
        e = self.elements
        force = self.work.empty("force", len(e.v), 3)
        np.subtract(e.v, self.v_start, out=force)
        force *= e.mass[:, None] / dt
        guests = self.swap_rows(force) if self.lending else np.zeros((0, 3))
        node_force = np.concatenate([force[self.mine], guests])
        if self.layered(state):
            total, cforce = state.part("force", state.force.shape), \
                state.part("cforce", contact.cforce.shape)
            width = cforce.shape[1] * cforce.shape[2]
            kf.node_forces_to_grid(
                self.pts, state.geometry, total, node_force, contact.slot_of, cforce, 0,
                state.layer_sums("force" + PART, 3, self.order),
                state.layer_sums("cforce" + PART, width, self.order, state.slot_starts))
            return 0.0
        kf.node_forces_to_grid(self.pts, state.geometry, state.force, node_force,
                               contact.slot_of, contact.cforce, state.index)
        return 0.0

    def grid_to_points(self, state, dt, contact):
        """The contact's velocity change (FLIP) on every copy of the coupled nodes, then
        their constraints and the grid faces again."""
        if state.index != 0:
            return
        fields = self.contact.fields[0]
        slots = fields.slots()
        n_slots, nb = slots.cnodal.shape[:2]
        dacc = self.work.empty("dacc", n_slots, 3 * nb).reshape(n_slots, nb, 3)
        kf.contact_accelerations(slots, self.rigid, self.m_tiny, state.nodes, dacc)
        dv = np.empty((len(self.pts.mass), 3))
        kf.contact_velocity_changes(self.pts, state.geometry, fields.slot_of, dacc, dt,
                                    self.rigid, dv, 0)
        self.apply(dv, dt)

    def apply(self, dv, dt):
        e = self.elements
        change = np.zeros_like(e.v)
        change[self.mine] = dv[:len(self.mine)]
        if self.lending:
            self.return_to_lenders(dv[len(self.mine):], change)
        change = sum_shared_rows(self.world, change, e.partners)
        if e.rigid_motion is not None:    # a free rigid body takes its nodes' sum
            e.rigid_motion.take_velocity_changes(e, change)
        e.v += change
        e.v[e.fixed] = 0.0
        e.hold_at_faces(dt)

    def return_to_lenders(self, guest_dv, change):
        """Send each guest's velocity change back to the rank that lent it."""
        edges = np.concatenate([[0], np.cumsum(self.guest_counts)])
        packages = [(guest_dv[edges[r]:edges[r + 1]],) for r in range(self.world.size)]
        received = exchange_arrays(self.world, packages)
        for r in range(self.world.size):
            change[self.lent[self.lent_to == r]] = received[r][0]

    # -- the blocks' extent ------------------------------------------------------------
    def spans(self, grids, grid):
        """Per level, (-lowest, highest) cell of the coupled nodes the next step maps
        (coarse level only), so that the blocks cover their shape functions. Called at
        the end of a step, after its transfers, or at set-up: nothing moves between this
        and the next map, so the near nodes are the same (blocks over every coupled node
        made the rolling sphere's CFEMP step 11 % slower). Collective."""
        _, x = self.positions()
        return grids.spans(grid, x, np.zeros(len(x), np.int32))


def grid_coupled_bodies(rules, fem):
    """(nb,) bool: the FEM bodies that meet some particle body on the grid."""
    fem = np.asarray(fem, bool)
    return fem & (rules.coupling == GRID_COUPLING).any(axis=1)


def check_grid_coupling(config, rules, coupled, elements, world):
    """SetupError naming the key of what grid coupling cannot do yet: an FEM body on the
    grid and on surface contact at once, MUSL, method 2 under APIC or a PIC blend, a
    refined window over (or following a body onto) a grid-coupled FEM body. Collective
    (the FEM bodies' box)."""
    problems = []
    names = [b.name for b in config.bodies]
    particles = np.array([not b.is_fem for b in config.bodies])
    surface = (rules.coupling == SURFACE_COUPLING) & particles[None, :]
    for b in np.flatnonzero(coupled & surface.any(axis=1)):
        problems.append(f"{pair_key(config.contact, names[b])}: FEM body '{names[b]}' meets "
                        f"some particle bodies on the grid and others by surface contact; "
                        f"give all its pairs one coupling")
    if config.time.scheme != "usf":
        problems.append(f"time.scheme: grid coupling (CFEMP) steps with usf only, not "
                        f"{config.time.scheme}")
    problems += start_correction_problems(config, rules)
    problems += window_problems(config, coupled, elements, world)
    if problems:
        raise SetupError(problems)


def start_correction_problems(config, rules):
    """Method 2's start-of-step correction (Eq. 25) reaches the particles' velocities
    under APIC (all of it) and a PIC blend (its share) but never the FE nodes, which take
    the grid's change over the step alone: the bodies' momenta would then not sum to what
    the contact keeps. Under FLIP (the default) neither takes it."""
    if rules.method != 2:
        return []
    if config.time.transfer == "apic":
        return ["time.transfer: apic with contact.method 2 and grid coupling (CFEMP): the "
                "FE nodes cannot take method 2's start correction the particles take, so "
                "momentum is not conserved; use flip, contact.method 1, or "
                "contact.coupling: surface"]
    if config.time.pic > 0:
        return [f"time.pic: {config.time.pic} with contact.method 2 and grid coupling "
                f"(CFEMP): the FE nodes cannot take the share of method 2's start "
                f"correction the particles take, so momentum is not conserved; use pic 0, "
                f"contact.method 1, or contact.coupling: surface"]
    return []


def pair_key(contact, name):
    for i, pair in enumerate(contact.pairs):
        if name in pair.bodies:
            return f"contact.pairs[{i}].coupling"
    return "contact.coupling"


def window_problems(config, coupled, elements, world):
    on = coupled[elements.node_body]
    x = elements.x[on]
    lo = world.min(x.min(axis=0) if len(x) else np.full(3, np.inf))
    hi = world.max(x.max(axis=0) if len(x) else np.full(3, -np.inf))
    grid = config.grid
    reach = float(grid.cell)
    problems = []
    for i, window in enumerate(grid.windows):
        if window.ratio <= 1:
            continue
        key = f"grid.windows[{i}]"
        if window.follow is not None:
            problems.append(f"{key}.follow: a moving window may reach a grid-coupled FEM "
                            f"body, whose nodes map to the coarse grid only")
        elif np.all(np.asarray(window.min) < hi + reach) and \
                np.all(np.asarray(window.max) > lo - reach):
            problems.append(f"{key}: overlaps a grid-coupled FEM body, whose nodes map to "
                            f"the coarse grid only (no refinement over it yet)")
    return problems


def grid_coupled_nodes(config, rules, elements, couplings, decomposition, grid, bodies,
                       m_tiny, points=None):
    """[FemGridNodes] when some FEM body meets a particle body on the grid (registered
    with the decomposition, so that the blocks cover its nodes), else []; SetupError for
    what grid coupling cannot do yet (:func:`check_grid_coupling`)."""
    if elements is None or not rules.active:
        return []
    coupled = grid_coupled_bodies(rules, [b.is_fem for b in config.bodies])
    if not coupled.any():
        return []
    check_grid_coupling(config, rules, coupled, elements, elements.world)
    contact = next(c for c in couplings if isinstance(c, GridContact))
    meets = (rules.coupling == GRID_COUPLING) & ~np.eye(len(coupled), dtype=bool)
    nodes = FemGridNodes(elements, contact, decomposition, grid, bodies, coupled, m_tiny,
                         points, meets)
    decomposition.span_sources.append(nodes)
    return [nodes]
