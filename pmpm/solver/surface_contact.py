"""ICFEMP (seed 004 Sec. 3, Eqs. 33-54): particles kept out of the free faces of FEM
bodies by a velocity (Lagrange multiplier) constraint with Coulomb friction.

The coupling acts once per step, after the grid and the FE nodes are integrated and the
particles have taken their grid-to-particle update (``after_update_points``): the
particles' FLIP velocities are the trial velocities v̄_p (Eq. 43), the FE nodes' new
half-step velocities the trial v̄_J, and both have moved to their trial positions.

* Master segments: the free faces (faces of exactly one element, found from the
  connectivity and, over MPI, the sharers' candidate faces: :meth:`refresh_faces`) of the
  FEM bodies a particle body meets with SURFACE_COUPLING; the particles are the slaves.
  Rigid particle bodies take no part.
* Global search (Eqs. 33-35), every step: each segment is entered in the buckets its box,
  inflated by ``reach`` (twice the largest particle half-spacing) plus the farthest any
  particle of the rank and any face node moved in the step, overlaps; a particle looks
  only at the segments of its own bucket. Nothing is missed: a segment the particle can
  touch or have got behind (below) has the particle inside its inflated box. The buckets
  cover only the particles' box, and a segment whose node box lies beyond the pair's
  window, or beyond the best segment found so far, is passed over before its Newton
  projection (the closest point lies in that box): the same pairs, to the bit.
* Local search (Eqs. 36-41): the closest point of the bilinear face by Newton, the
  outward normal n and the gap g = n.(x_p - r_c) at the trial positions.
* Contact rule: the particle is a sphere of half its spacing r_p = vol0^(1/3) / 2; it is
  in contact with the nearest face for which g < r_p, the closest point lies within r_p
  of the foot of the normal, and its centre is on the face's side: at most r_p plus what
  particle and face moved in the step behind it (a centre that was out cannot skip this
  window in one step, however fast), and not deeper than r_p behind the face at the
  start of the step (from the start-of-step positions kept by ``after_scatter``: the
  far faces of the body, and a face that a centre crossing a thin body reaches from
  behind, are not taken). Only a pair that approaches, (v̄_p - v̄_c).n < 0, takes an
  impulse. The velocity constraint stops the approach but does not undo a depth already
  reached (positions follow the grid velocities, which the constraint does not see), so
  every pair whose centre is inside (g < 0), approaching or not, also moves the
  particle's position out along n (:func:`closure`): by GAP_CLOSURE of a depth within
  r_p (the notes' gap closure, done on the position only: as a velocity it made a
  resting sphere bounce), and onto the face from a deeper one. Before issue 24 Sec. 4
  only approaching pairs with -r_p < g were found: a centre inside a face it no longer
  approached stayed there, and one that crossed more than r_p in a step went through
  unseen (tests/test_surface_contact_search.py). Tests check that the centres stay out
  of the plate, hit at 2 m/s or sliding on it under gravity, or at 20 m/s thrown at a
  plate thinner than a step's move. ``largest_penetration``: the deepest centre of the
  step (at the trial positions, before any correction); :meth:`deepest_centre`: of the
  run, over all ranks (summary.json ``surface_contact.largest_penetration``).
* Impulse (Eqs. 42-53): the stick impulse with Coulomb's cap (pmpm.kernels.
  surface_contact.pair_impulse), met on the particle body's grid (issue 24 Sec. 4,
  :meth:`push_grid`; seed 004's Eq. 54 puts the contact force on the grid): a pair
  approaches by the grid velocity at its particle; its "surface nodes", those the
  particle reads no farther from the face than it, with weights W_Ik = N_Ip renormalised
  over them, each meet the face point by the stick impulse between node I, lent W_Ik m_I
  / S_I (S_I = sum_k W_Ik over the pairs of all ranks), and the face, lent W_Ik of the
  pair's share. Node I takes minus the sum of its rows; every particle that read it in
  this step's grid-to-particle update takes its velocity change (velocity, dt times it on
  its position, APIC matrix), so the particles sharing a node at the face with a pair
  take the contact force too (on the particle alone, that node carried the body's stress
  unbalanced and its other particles took the acceleration: a particle striker never
  stopped on an FEM bar). Then what is left of the pair particle's own (FLIP) approach,
  against the face point moved by the pair's impulse, takes the stick impulse with the
  particle's mass (:meth:`stop_particles`; without it the sphere on the block lost 9-20 %
  of its energy). Each FE node J of the face takes phi_J times the pair's impulses on its
  velocity and dt phi_J I/m_J on its position; rigid FEM bodies and held node components
  take nothing, but a free rigid body (``rigid.free``) takes the sum of its pairs'
  impulses on its velocity, each pair meeting a share of the body's mass
  (pmpm.solver.rigid_motion). Pairs are solved at once (Jacobi); so that many particles on one light
  face do not over-correct it, a node J lends pair k the share phi_J^k / Phi_J of its
  mass, Phi_J = sum_k phi_J^k over the approaching pairs (1/m_c = sum_J phi_J^k Phi_J /
  m_J; a pair alone on its nodes gets Eq. 49): a layer of particles that tiles a face and
  moves alike is stopped in one step, as one merged node would be, and momentum stays
  exact since every node still takes the full sum of its impulses. (Lending m_J / n_J to
  each of n_J pairs, as before issue 24, left a tiled face 22 % short of stopping each
  step, so its pairs met again every step as a train of small inelastic collisions: an
  elastic sphere on an elastic block lost 77 % of its energy;
  docs/validation/surface_contact_impact.md.) Faces on a held face of the grid box
  (slip, symmetry, fixed) are no contact faces (:func:`on_held_box_faces`).
* Energy: a pair that stays in contact meets, each step, with only the relative
  velocity its bodies' forces built up in that step, and the stick impulse joins the
  two sides as one node would; the energy balance (solver.energy) falls only through
  friction and the first blow of an impact; the gap closure's position shifts are not counted (in the sphere runs of
  docs/validation/sphere_rolling_fem.md the balance rises at most 2 %, while the soft
  sphere settles).

MPI: elements (and so segments) live on the rank of their centroid's slab, particles on
the rank of their position's slab. Each step a rank sends copies of its segments whose
box, grown by how far their nodes moved, meets the box of another rank's particles of a
body they touch, grown by the particles' reach (a halo; one allgather of per-body boxes
and no global gather: pmpm.solver.contact_halo). Each pair
is computed on the particle's owner. The phi sums Phi_J of nodes go to the node's lowest
holder, summed there in (node id, particle id) order, and back; the node impulses go to every rank that holds the node, where they are
summed in (node id, particle id) order: every copy of a shared node takes the same total,
and 1 rank agrees with N to round-off (the sums are pmpm.solver.contact_sums', shared with
node-to-surface contact between FEM bodies, pmpm.solver.node_contact). The four exchanges of a step (halo, phi
sums and their answers, impulses) are packed sparse exchanges (pmpm.comm.sparse):
a rank sends one buffer to each rank that gets something from it, none to the others. The grid side's S_I and nodal impulses are grid fields, summed over
the shared slab planes as the nodal masses are (two more sums a step).
"""
import numpy as np

from ..comm.shared_nodes import swap_with
from ..fem.hexahedron import FACES
from ..kernels.boundary import FREE, column_kinds
from ..kernels.face_match import matches_in, matching_face_counts
from ..kernels import node_contact as knc
from ..kernels import surface_contact as ksc
from ..kernels.portable import cube_roots
from .contact import SURFACE_COUPLING
from .contact_halo import body_boxes, exchange_halo, grown
from .contact_sums import (node_holders, pad_holders, sums_at_holders, sums_at_home,
                           sums_in_order)
from .couplings import Coupling, kept_copy

#: the share of a particle centre's depth inside a face that its pair closes in a step,
#: by moving the particle's position out (not its velocity: no energy, no momentum)
GAP_CLOSURE = 0.5
#: the most buckets of the global search (their size grows beyond a face's to keep to it)
MAX_BUCKETS = 2 ** 21
#: how the grid fields of the particle side reflect across planes of symmetry
SCALAR_KINDS, VECTOR_KINDS = column_kinds(1), column_kinds(3, velocity=(0,))
SEGMENT_FIELDS = ("gid", "x", "x0", "v", "inv_m", "body", "key", "holders")
#: the halo's boxes grown by this share of a cell more than the reach, against round-off
HALO_SLACK = 1e-6


class SurfaceContact(Coupling):
    """Particle-to-surface contact of the particle bodies and FEM bodies that meet with
    SURFACE_COUPLING.

    Parameters
    ----------
    rules : solver.contact.ContactRules   ``coupling`` and ``friction`` per pair
    world : comm.World
    points : solver.particle_bodies.ParticleBodies
    elements : solver.fem_bodies.FemBodies
    grid : grid.CoarseGrid   (origin, cell) for the slabs' extents
    decomposition : solver.decomposition.Decomposition   the current slabs
    """

    def __init__(self, rules, world, points, elements, grid, decomposition):
        self.world, self.points, self.elements = world, points, elements
        self.grid, self.decomposition = grid, decomposition
        self.segment_rows = SegmentRows()
        nb = len(rules.coupling)
        fem = np.zeros(nb, bool)
        fem[elements.body_indices] = True
        rigid = np.asarray(points.bodies.rigid, bool)
        surface = rules.coupling == SURFACE_COUPLING
        self.touches = surface & ~fem[:, None] & fem[None, :] & ~rigid[:, None]
        spacing = grid.h * points.bodies.born_spacing
        # the particles born of an FEM body's elements meet what is left of its own mesh
        # and every FEM body it meets with surface coupling (BodyTable.born_spacing)
        born = points.bodies.meets_own_mesh
        self.touches |= born[:, None] & fem[None, :] & (surface | np.eye(nb, dtype=bool))
        self.masters, self.slave_bodies = self.touches.any(axis=0), self.touches.any(axis=1)
        self.friction = np.ascontiguousarray(rules.friction, np.float64)
        p = points.particles
        slave = self.slave_bodies[p.body]
        local = float(half_spacing(p.vol0[slave]).max()) if slave.any() else 0.0
        local = max(local, 0.5 * float(spacing.max(initial=0.0)))
        self.reach = 2.0 * world.max(local)
        self.last_pairs, self.largest_penetration, self.deepest = 0, 0.0, 0.0
        self.force_log = None          # pmpm.solver.forces.ForceLog, set by the simulation
        self.start_x = self.start_node_x = None
        self.grids = None              # the step's grid levels, kept by after_scatter
        self.refresh_faces()

    # -- the master segments --------------------------------------------------------
    def refresh_faces(self):
        """The free faces of this rank's elements of master bodies (collective among the
        ranks that share nodes): ``face_nodes`` (nf, 4) local node indices, ``face_key``
        element id * 6 + face; and each local node's holders (ranks, padded with -1).
        Every rank calls it again whenever the elements it holds change (the FEM kind's
        ``elements_changed``: migration, and elements removed, whose neighbours' faces
        become free)."""
        fem = self.elements
        faces, key, free, self.holders = mesh_faces(self.world, fem)
        master = np.repeat(self.masters[fem.body], 6)
        keep = free & master & ~on_held_box_faces(fem.x, faces, self.grid)
        self.face_nodes = np.ascontiguousarray(faces[keep])
        self.face_key = key[keep]
        # per segment node: 1 / m, 0 where the node takes no impulse (held in every
        # component, or rigid); masses and holds do not change between refreshes
        inv_m = np.where(fem.fixed.all(axis=1), 0.0, 1.0 / fem.mass)
        inv_m[fem.rigid_nodes()] = 0.0
        self.face_inv_m = inv_m[self.face_nodes]
        self.face_gid = fem.node_id[self.face_nodes]
        self.face_body = fem.node_body[self.face_nodes[:, 0]].astype(np.int64)
        self.face_holders = self.holders[self.face_nodes]

    def after_elements_changed(self):
        self.refresh_faces()

    def own_segments(self):
        """This rank's segments with their nodes' current state (what does not change
        between refreshes is kept from :meth:`refresh_faces`)."""
        fem = self.elements
        fixed = {"gid": self.face_gid, "inv_m": self.face_inv_m, "body": self.face_body,
                 "key": self.face_key, "holders": self.face_holders}
        return self.segment_rows.own(fixed, fem.x, self.start_node_x, fem.v,
                                     self.face_nodes)

    def particle_moves(self):
        """How far each particle moved in the step so far (0 for particles of bodies that
        meet no face): the search's and the halo's part of the reach."""
        p = self.points.particles
        slave = self.slave_bodies[p.body]
        return np.where(slave, np.linalg.norm(p.x - self.start_x, axis=1), 0.0)

    def with_halo(self, own, moved):
        """Own segments plus copies of the other ranks' segments that may reach this
        rank's particles (collective; pmpm.solver.contact_halo): a segment's box grown
        by how far its nodes moved in the step meets the box of the particles of a body
        it touches grown by their part of the reach, twice the largest radius plus the
        farthest one moved (a pair's centre lies within r + (r + moved + seg_move) of its
        face, kernel ``find_pairs``; ``moved``: :meth:`particle_moves`)."""
        if self.world.size == 1:
            return own
        p = self.points.particles
        slave = np.flatnonzero(self.slave_bodies[p.body])
        x = p.x[slave]
        farthest = moved[slave].max(initial=0.0)
        radius = half_spacing(p.vol0[slave]).max(initial=0.0)
        slack = HALO_SLACK * self.grid.h
        points = grown(body_boxes(x, x, p.body[slave], len(self.touches)),
                       2.0 * radius + farthest + slack)
        seg_move = np.empty(len(own["x"]))
        ksc.segment_moves(own["x"], own["x0"], seg_move)
        lo, hi = np.empty((len(seg_move), 3)), np.empty((len(seg_move), 3))
        knc.segment_boxes(own["x"], seg_move + slack, lo, hi)
        received = exchange_halo(self.world, own, SEGMENT_FIELDS, lo, hi, points,
                                 self.touches)
        me = self.world.rank
        return self.segment_rows.joined(received[:me] + received[me + 1:])

    # -- the step ---------------------------------------------------------------------
    def after_scatter(self, grids, kinds):
        """Keep the start-of-step positions of the particles and FE nodes: the search
        tells from them on which side of a face a centre that is now inside it was, and
        the particles read the grid from theirs (:meth:`push_particles`)."""
        self.grids = grids
        self.start_x = kept_copy(self.start_x, self.points.particles.x)
        self.start_node_x = kept_copy(self.start_node_x, self.elements.x)

    def after_update_points(self, dt):
        moved = self.particle_moves()
        segs = self.with_halo(self.own_segments(), moved)
        found_p, found_s, found_geo = self.find_pairs(segs, moved)
        phi = shapes(found_geo[:, 0], found_geo[:, 1])
        p = self.points.particles
        v_c = np.einsum("kj,kjd->kd", phi, segs["v"][found_s])
        v_grid = self.grid_velocities(found_p)
        closing = -np.einsum("kd,kd->k", v_grid - v_c, found_geo[:, 2:5])
        approach = closing > 0.0
        pair_p, pair_s, geo, phi = found_p[approach], found_s[approach], \
            found_geo[approach], phi[approach]
        lent_inv_m = segs["inv_m"] * self.phi_sums(segs, pair_p, pair_s, phi)
        rigid, bodies = self.elements.rigid_motion, segs["body"][pair_s]
        rows = self.surface_rows(pair_p, geo[:, 2:5])
        if rigid is not None:       # free rigid faces lend a share of their body's mass
            lent = rigid.lent_inverse_mass(bodies, geo[:, 2:5], lent_inv_m[pair_s],
                                           self.pair_masses(rows, len(pair_p))
                                           * closing[approach])
            faces = np.arange(len(pair_p)), segs["v"][pair_s], lent
        else:
            lent = lent_inv_m[pair_s]
            faces = pair_s, segs["v"], lent_inv_m
        pair = dict(p=pair_p, geo=geo, faces=faces, v_c=v_c[approach], bodies=bodies,
                    friction=self.friction[p.body[pair_p], bodies])
        impulses = self.push_grid(rows, pair, dt)
        lift = np.zeros(len(found_p))
        lift[approach] = self.lifts(pair_p, geo, dt)
        residual, more_lift = self.stop_particles(pair, impulses, phi, lent, dt)
        lift[approach] += more_lift
        self.close_gaps(found_p, found_geo, lift)
        impulses += residual
        self.push_nodes(segs, pair_p, pair_s, phi, impulses, dt)
        if rigid is not None:
            rigid.take_impulses(self.elements, bodies, p.id[pair_p], impulses, dt)
        self.last_pairs = len(pair_p)

    # -- the particle side on the grid ---------------------------------------------------
    def level_pairs(self, state, pair_p):
        """The pairs (indices into ``pair_p``) whose particle is on grid level ``state``."""
        return np.flatnonzero(self.points.level_of[pair_p] == state.index)

    def grid_velocities(self, pair_p):
        """Per pair, the new grid velocity at its particle, sum_I N_Ip v_I: what the
        particle moved with in this step (the shared field: at a node of grid contact
        between particle bodies, their common velocity)."""
        p, out = self.points.particles, np.zeros((len(pair_p), 3))
        for s in self.grids:
            k = self.level_pairs(s, pair_p)
            part = np.empty((len(k), 3))
            ksc.gather_from_nodes(self.start_x, pair_p[k], p.body, s.geometry,
                                  s.gnew[:, :3], part)
            out[k] = part
        return out

    def surface_rows(self, pair_p, normals):
        """Per level, the rows (node, pair, weight W_Ik) of the particle body's grid
        nodes that stand for its surface at each pair (kernel ``surface_nodes``), and on
        every node S_I = sum of W_Ik over the pairs of all ranks (``sc_share``,
        collective): node I lends pair k the share W_Ik / S_I of its mass, so that pairs
        alike on one node stop it together in one step, as one pair would."""
        p, grids, rows = self.points.particles, self.grids, []
        grids.zeros("sc_share", 1)
        for s in grids:
            k = self.level_pairs(s, pair_p)
            size = len(k) * ksc.MAX_NODES
            node, pair, weight = np.empty(size, np.int64), np.empty(size, np.int64), \
                np.empty(size)
            n = ksc.surface_nodes(self.start_x, pair_p[k], p.body,
                                  np.ascontiguousarray(normals[k]), s.geometry,
                                  node, pair, weight)
            rows.append((node[:n], k[pair[:n]], weight[:n]))
            particle = pair_p[k[pair[:n]]]
            s.add_rows("sc_share", s.sc_share, node[:n], self.start_x[particle],
                       p.id[particle], weight[:n, None])
        grids.sum_shared("sc_share")
        grids.reflect("sc_share", SCALAR_KINDS)
        return rows

    def pair_masses(self, rows, n_pairs):
        """Per pair, the grid mass its surface nodes lend it: sum_I W_Ik m_I / S_I."""
        mass = np.zeros(n_pairs)
        for s, (node, pair, weight) in zip(self.grids, rows):
            share = np.maximum(s.sc_share[node, 0], 1e-300)
            np.add.at(mass, pair, weight * node_masses(s)[node] / share)
        return mass

    def push_grid(self, rows, pair, dt):
        """The contact on the particle body's grid (collective): each surface node I of
        pair k meets the pair's face point C by a stick impulse between I (lent W_Ik m_I
        / S_I, at its new velocity) and C (lent W_Ik of the face's share), kernel
        ``node_pair_impulses``. Node I takes minus the sum of its rows; its new velocity
        changes by that over m_I (after the grid's faces), and every particle that read
        it in this step's grid-to-particle update takes the change as it would have then
        (velocity, position, APIC matrix): the contact force stands on the grid, as seed
        004's Eq. 54 puts it, and the particles that share the surface nodes without
        touching the face take it too (on the particle alone, the node that carries the
        body's stress at the face was left unbalanced, and the particles sharing it
        without touching the face took its acceleration). Returns per pair the sum of its
        rows' impulses (what its face takes)."""
        p, grids = self.points.particles, self.grids
        impulses = np.zeros((len(pair["p"]), 3))
        seg_s, seg_v, seg_inv_m = pair["faces"]
        grids.zeros("sc_impulse", 3)
        for s, (node, k, weight) in zip(grids, rows):
            mass, share = node_masses(s), s.sc_share[:, 0]
            row_impulses = np.empty((len(node), 3))
            ksc.node_pair_impulses(node, k, weight, mass, share, s.gnew[:, :3], seg_s,
                                   pair["geo"], seg_v, seg_inv_m, pair["friction"],
                                   row_impulses)
            particle = pair["p"][k]
            s.add_rows("sc_impulse", s.sc_impulse, node, self.start_x[particle],
                       p.id[particle], -row_impulses)
            np.add.at(impulses, k, row_impulses)
            if self.force_log is not None:       # before the velocities change
                self.log_rows(s, (node, k, weight), row_impulses, pair)
        grids.sum_shared("sc_impulse")
        grids.reflect("sc_impulse", VECTOR_KINDS)
        rigid = np.asarray(self.points.bodies.rigid, np.bool_)
        for s in grids:
            s.sc_dv = s.work.empty("sc_dv", s.block.n_nodes, 3)
            s.sc_moved = ksc.nodal_velocity_changes(s.nodal, s.sc_impulse, s.gnew,
                                                    s.nodes.faces, s.nodes.friction,
                                                    s.sc_dv)
            if s.sc_moved:
                ksc.take_velocity_changes(self.start_x, p.x, p.v, p.body,
                                          self.points.level_of, rigid, s.index,
                                          s.geometry, s.sc_dv, near_changes(s.block,
                                                                            s.sc_dv),
                                          dt, self.points.affine())
        return impulses

    def lifts(self, pair_p, geo, dt):
        """How far out along its normal each pair's particle moved by the nodes' velocity
        changes (:meth:`push_grid`)."""
        p, lift = self.points.particles, np.zeros(len(pair_p))
        for s in self.grids:
            if not s.sc_moved:
                continue
            k = self.level_pairs(s, pair_p)
            change = np.empty((len(k), 3))
            ksc.gather_from_nodes(self.start_x, pair_p[k], p.body, s.geometry, s.sc_dv,
                                  change)
            lift[k] = dt * np.einsum("kd,kd->k", change, geo[k, 2:5])
        return lift

    def stop_particles(self, pair, impulses, phi, lent, dt):
        """What the grid leaves of each pair particle's own approach: under FLIP a
        particle keeps its own velocity, which the grid's stop changes by the nodes'
        change but does not bring to the face's; what still approaches came back through
        the next step's particle-to-grid transfer and met the face again, as a train of
        small inelastic blows (sphere on the block, 1 mm: energy -9 %, with this +3 %).
        The particle meets its face point, moved by the pair's impulse over the mass its
        face lends, by the stick impulse of Eqs. 42-53 with its own mass; it takes minus
        that on its velocity and dt times it over m_p on its position. Returns those
        impulses (the face's to take) and how far out each particle moved."""
        p, pair_p = self.points.particles, pair["p"]
        inv_c = np.einsum("kj,kj->k", phi, lent)
        v_face = pair["v_c"] + impulses * inv_c[:, None]
        residual = np.zeros((len(pair_p), 3))
        own = np.arange(len(pair_p))
        ksc.pair_impulses(own, own, pair["geo"], p.mass[pair_p], p.v[pair_p], own,
                          np.repeat(v_face[:, None, :], 4, axis=1), lent,
                          np.zeros(len(pair_p), np.int64),
                          np.ascontiguousarray(pair["friction"][:, None]), residual)
        share = residual / p.mass[pair_p, None]
        p.v[pair_p] -= share
        p.x[pair_p] -= dt * share
        if self.force_log is not None:
            self.force_log.surface_pairs(p.body[pair_p], pair["bodies"], residual,
                                         pair["geo"][:, 2:5], p.v[pair_p] + share - v_face,
                                         1.0 / p.mass[pair_p] + inv_c)
        return residual, -dt * np.einsum("kd,kd->k", share, pair["geo"][:, 2:5])

    def log_rows(self, state, rows, row_impulses, pair):
        """The force log's record of one level's rows: row r gave the particle's body
        -impulses[r] and the face's body +impulses[r]; its relative velocity is v_I -
        v_C, its inverse mass that of its stick impulse over W (so that the logged work
        is the row's)."""
        node, k, weight = rows
        seg_s, _, seg_inv_m = pair["faces"]
        face_phi = shapes(pair["geo"][k, 0], pair["geo"][k, 1])
        inv_c = np.einsum("kj,kj->k", face_phi, seg_inv_m[seg_s[k]])
        inv_i = state.sc_share[node, 0] / np.maximum(node_masses(state)[node], 1e-300)
        p = self.points.particles
        self.force_log.surface_pairs(
            p.body[pair["p"][k]], pair["bodies"][k], row_impulses, pair["geo"][k, 2:5],
            state.gnew[node, :3] - pair["v_c"][k], (inv_i + inv_c) / weight)

    def close_gaps(self, pair_p, geo, lift):
        """Every pair whose particle centre is inside its face, approaching or not, moves
        the centre out along the normal (the position only: no energy, no momentum;
        ``lift``: how far out the pair's impulse already moved it): see :func:`closure`.
        Records the deepest centre of the step (before any move) and of the run so far
        (this rank's)."""
        p = self.points.particles
        depth = approach_depth(geo)
        radius = half_spacing(p.vol0[pair_p])
        p.x[pair_p] += closure(depth, radius, lift)[:, None] * geo[:, 2:5]
        self.largest_penetration = float(depth.max()) if len(depth) else 0.0
        self.deepest = max(self.deepest, self.largest_penetration)

    def deepest_centre(self):
        """The deepest particle centre behind a face found so far in the run, over all
        ranks (collective)."""
        return self.world.max(self.deepest)

    def find_pairs(self, segs, moved):
        """(particle index, segment index, geometry (xi, eta, n, g)) of every particle in
        contact with a segment (before the approach test). Each face's box is grown by
        ``reach`` plus the farthest any particle of this rank and any face node moved in
        the step, the depth a centre may reach behind a face (kernel ``find_pairs``)."""
        p = self.points.particles
        if not len(segs["key"]) or not p.n:
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 6))
        x, x0 = np.ascontiguousarray(segs["x"]), np.ascontiguousarray(segs["x0"])
        seg_move = np.empty(len(x))
        ksc.segment_moves(x, x0, seg_move)
        grow = self.reach + moved.max() + seg_move.max()
        seg_lo, seg_hi, lo, hi = segment_boxes(x, np.full(len(x), grow))
        lo, hi = within_points(lo, hi, p.x, grow)
        if np.any(hi < lo):       # no particle lies in any face's grown box
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 6))
        edge = np.linalg.norm(x[:, 1] - x[:, 0], axis=1).mean()
        extent = hi - lo
        size = max(edge, 2.0 * self.reach, float(np.prod(extent) / MAX_BUCKETS) ** (1 / 3))
        dims = np.maximum(np.ceil(extent / size).astype(np.int64), 1)
        start, items = ksc.bucket_segments(seg_lo, seg_hi, lo, 1.0 / size, dims)
        pair_seg, geo = np.empty(p.n, np.int64), np.empty((p.n, 6))
        ksc.find_pairs(p.x, self.start_x, p.body.astype(np.int64), p.vol0, moved,
                       x, x0, seg_move, segs["body"], segs["key"], self.touches, lo,
                       1.0 / size, dims, start, items, pair_seg, geo)
        pair_p = np.flatnonzero(pair_seg >= 0)
        return pair_p, pair_seg[pair_p], geo[pair_p]

    def phi_sums(self, segs, pair_p, pair_s, phi):
        """(ns, 4): per segment node J, Phi_J = sum of phi_J over the approaching pairs of
        all ranks that touch it (0 where none does). Each rank sends its (node id,
        particle id, phi) rows to the node's lowest holder, which sums them in (node id,
        particle id) order and answers with the totals: the same sums on any rank count."""
        gid = segs["gid"][pair_s].ravel()
        pid = np.repeat(self.points.particles.id[pair_p], 4)
        rows = phi.ravel()
        if self.world.size == 1:
            ids, total = sums_in_order(gid, pid, rows)
        else:
            home = segs["holders"][pair_s][:, :, 0].ravel()
            ids, total = self.sums_over_ranks(gid, pid, rows, home)
        every = segs["gid"].ravel()
        at = np.minimum(np.searchsorted(ids, every), max(len(ids) - 1, 0))
        found = (ids[at] == every) if len(ids) else np.zeros(len(every), bool)
        sums = np.where(found, total[at] if len(ids) else 0.0, 0.0)
        return sums.reshape(segs["gid"].shape)

    def sums_over_ranks(self, gid, pid, rows, home):
        """(node ids, sums of ``rows``) of the nodes in ``gid``, over all ranks, each
        summed on the node's lowest holder in (node id, particle id) order."""
        return sums_at_home(self.world, gid, pid, rows, home)

    def push_nodes(self, segs, pair_p, pair_s, phi, impulses, dt):
        """The node impulses phi_J I to every holder of node J, summed there in (node id,
        particle id) order; velocities and positions of the free components move (not
        those the constraints or the grid faces hold)."""
        fem, p = self.elements, self.points.particles
        gid = segs["gid"][pair_s].ravel()
        pid = np.repeat(p.id[pair_p], 4)
        rows = (phi[:, :, None] * impulses[:, None, :]).reshape(-1, 3)
        holders = segs["holders"][pair_s].reshape(len(gid), segs["holders"].shape[2])
        nodes, total = sums_at_holders(self.world, gid, pid, rows, holders, fem.node_id)
        total[fem.fixed[nodes]] = 0.0
        total[fem.rigid_nodes()[nodes]] = 0.0
        before = fem.v.copy()
        fem.v[nodes] += total / fem.mass[nodes, None]
        fem.hold_at_faces(None)            # a node on a fixed or slip grid face stays held
        fem.x += dt * (fem.v - before)


def segment_boxes(seg_x, pad):
    """Each segment's box grown by its ``pad`` (seg_lo, seg_hi: (ns, 3)) and the box of
    them all (lo, hi: (3,))."""
    seg_lo, seg_hi = np.empty((len(seg_x), 3)), np.empty((len(seg_x), 3))
    knc.segment_boxes(seg_x, pad, seg_lo, seg_hi)
    lo, hi = np.empty(3), np.empty(3)
    ksc.box_bounds(seg_lo, seg_hi, lo, hi)
    return seg_lo, seg_hi, lo, hi


def within_points(lo, hi, x, pad):
    """The box [lo, hi] cut to the box of the points ``x`` grown by ``pad``: the buckets
    of the search need cover only where particles are (a particle outside every face's
    grown box has no pair, and one inside finds every face whose grown box holds it in
    its bucket, wherever the buckets start), so that a few particles by a large mesh do
    not bucket all of its faces. The pad keeps the outermost particles off the box's
    far side, where round-off could put them one bucket past the last."""
    x_lo, x_hi = np.empty(3), np.empty(3)
    ksc.box_bounds(x, x, x_lo, x_hi)
    return np.maximum(lo, x_lo - pad), np.minimum(hi, x_hi + pad)


def on_held_box_faces(x, faces, grid):
    """Which faces (rows of 4 node indices into ``x``) lie on a face of the grid box that
    holds its nodes there (slip, symmetry, fixed): their outward normal points out of the
    box, where no particle can be, so they are no contact faces. A quarter model's faces
    on its planes of symmetry are interior faces of the whole body: taken as contact
    faces, they pulled the sphere's particles beside them onto the plane (the sphere on
    the block at 0.5 mm: centres 0.12 mm behind them, halved each step)."""
    lo = grid.origin
    hi = grid.origin + grid.n_cells * grid.h
    tol = 1e-9 * grid.h
    on = np.zeros(len(faces), bool)
    for d in range(3):
        for side, plane in enumerate((lo[d], hi[d])):
            if grid.boundary[2 * d + side] != FREE:
                on |= (np.abs(x[faces][:, :, d] - plane) <= tol).all(axis=1)
    return on


def near_changes(block, dv):
    """Per node of ``block``: whether it or a node next to it (27 about it) has a
    velocity change in ``dv``."""
    cube = (dv != 0.0).any(axis=1).reshape(tuple(block.shape[block.order]))
    for axis in range(3):
        grown = cube.copy()
        ahead = [slice(None)] * 3
        behind = [slice(None)] * 3
        ahead[axis], behind[axis] = slice(1, None), slice(None, -1)
        grown[tuple(ahead)] |= cube[tuple(behind)]
        grown[tuple(behind)] |= cube[tuple(ahead)]
        cube = grown
    return cube.ravel()


def node_masses(state):
    """A level's nodal masses, 0 where a rigid body imposes the velocity."""
    return np.where(state.nodal[:, 4] > 0.0, 0.0, state.nodal[:, 0])


class SegmentRows:
    """The segments a contact searches in a step, this rank's rows first and then the
    halo's, in arrays kept from step to step: the own rows' fixed fields (everything but
    the nodes' positions and velocities) are written once after each refresh of the
    faces, their positions and velocities gathered in place each step, and only the
    halo's rows are copied after the exchange. Joining fresh arrays each step cost 1.5 s
    of 21 on each rank of the 2 mm perforation on 2 ranks (two contacts, 4,500 own faces
    against 700 of the halo). Holder lists are padded with -1 to the widest seen."""

    MOVING = ("x", "x0", "v")

    def __init__(self):
        self.arrays, self.fixed_of, self.n_own = {}, None, 0

    def own(self, fixed, x, x0, v, nodes):
        """This rank's segments (views): the fields ``fixed`` (dict; the same arrays
        until the faces are refreshed) and the positions, start-of-step positions and
        velocities of the nodes ``nodes`` (ns, 4)."""
        n = len(nodes)
        if self.fixed_of is not fixed["gid"]:          # new faces: write the fixed rows
            self.fixed_of, self.n_own = fixed["gid"], 0   # (the old rows are not kept)
            self.reserve(fixed, n, fixed["holders"].shape[2])
            for k, column in fixed.items():
                self.put(k, 0, column)
        self.n_own = n
        a = self.arrays
        ksc.gather_segments(x, x0, v, nodes, a["x"][:n], a["x0"][:n], a["v"][:n])
        return self.rows(n)

    def joined(self, halos):
        """The own rows of this step followed by those of ``halos`` (segment dicts, in
        rank order; those without rows skipped)."""
        halos = [h for h in halos if len(h["gid"])]
        count = self.n_own + sum(len(h["gid"]) for h in halos)
        width = max([self.arrays["holders"].shape[2]] + [h["holders"].shape[2]
                                                         for h in halos])
        self.reserve(halos[0] if halos else None, count, width)
        start = self.n_own
        for halo in halos:
            for k, column in halo.items():
                self.put(k, start, column)
            start += len(halo["gid"])
        return self.rows(count)

    def rows(self, n):
        return {k: column[:n] for k, column in self.arrays.items()}

    def put(self, field, start, column):
        target = self.arrays[field][start:start + len(column)]
        if field == "holders":
            target[...] = -1
            target[..., :column.shape[2]] = column
        else:
            target[...] = column

    def reserve(self, template, rows, width):
        """Room for ``rows`` rows and holder lists ``width`` wide, keeping the own rows
        (``template``: a dict of the fixed fields, for their dtypes and shapes, where
        there are no arrays yet)."""
        a = self.arrays
        if a and len(a["gid"]) >= rows and a["holders"].shape[2] >= width:
            return
        size, n = max(rows * 5 // 4, 64), self.n_own
        width = max(width, a["holders"].shape[2] if a else 0)
        grown = {k: np.zeros((size, 4, 3)) for k in self.MOVING}
        for k, column in (a or template).items():
            if k == "holders":
                grown[k] = np.full((size, 4, width), -1, np.int64)
            elif k not in self.MOVING:
                grown[k] = np.zeros((size,) + column.shape[1:], column.dtype)
        for k, column in a.items():            # the own rows of this step
            if k == "holders":
                grown[k][:n, :, :column.shape[2]] = column[:n]
            else:
                grown[k][:n] = column[:n]
        self.arrays = grown


def approach_depth(geo):
    """How deep each pair's particle centre is inside its face (0 when outside)."""
    return np.maximum(0.0, -geo[:, 5])


def closure(depth, radius, lift):
    """How far a centre ``depth`` behind its face at the trial position moves out in a
    step, beyond the ``lift`` its impulse gave it. Within its radius (the contact
    window of a centre that was already touching): GAP_CLOSURE of the depth, as a
    partial step that does not undo the velocity constraint's work. Deeper (a centre
    that crossed the face in this step faster than the window is wide): back onto the
    face, all of the depth the impulse left, so that the next step starts within the
    radius of the face it came through and the search keeps the pair."""
    left = np.maximum(0.0, depth - lift)
    return np.where(depth > radius, left, GAP_CLOSURE * depth)


def half_spacing(vol0):
    """A particle's radius: half its spacing, vol0^(1/3) / 2."""
    return 0.5 * cube_roots(np.ascontiguousarray(vol0, np.float64))


def shapes(xi, eta):
    """(k, 4) bilinear face shape functions at (xi, eta) (Eq. 37)."""
    return (0.25 * (1.0 + ksc.XI[None, :] * xi[:, None])
            * (1.0 + ksc.ETA[None, :] * eta[:, None]))


def mesh_faces(world, fem):
    """(faces, key, free, holders) of the FEM kind ``fem``'s elements: their faces as rows
    of 4 local node indices (six per element), each face's key (element id * 6 + face),
    which are free over all ranks (:func:`shared_faces_taken`), and each local node's
    holders. Kept in ``fem.face_cache`` while its mesh stays (``mesh_version``), so that the
    couplings that rebuild their faces on one change (surface and node contact) find them
    once: at the seed's 1 mm perforation (1.9 million faces) elements convert at about
    every other step."""
    faces = fem.hexes[:, FACES].reshape(-1, 4)
    key = (fem.element_id[:, None] * 6 + np.arange(6)).ravel().astype(np.int64)
    kept = fem.face_cache
    if kept is not None and kept[0] == fem.mesh_version:
        return (faces, key) + kept[1]
    gids = fem.node_id[faces]
    counts = local_face_counts(kept, fem.last_removal, fem.mesh_version, gids)
    free = shared_faces_taken(world, faces, gids, counts == 1, fem.node_id, fem.partners)
    holders = node_holders(world.rank, fem.partners, len(fem.x))
    # kept: what is not a gather of the connectivity (the faces and keys are made again
    # per call: 0.23 kB an element less to hold through the run)
    fem.face_cache = (fem.mesh_version, (free, holders), counts)
    return faces, key, free, holders


def local_face_counts(kept, removal, version, gids):
    """(n,) for each face (``gids``: its global node ids) how many of this rank's faces
    have its four nodes. After a removal alone (``removal``: the version it changed, the
    elements kept, the removed elements' faces' node ids) the counts kept from the mesh
    before less the removed faces that matched (removal keeps the elements' order): one
    pass over the faces with a small table, not a table of all of them."""
    if kept is not None and removal is not None and removal[0] == kept[0] == version - 1:
        keep = np.repeat(removal[1], 6)
        if keep.sum() == len(gids):
            return kept[2][keep] - matches_in(gids, removal[2]).astype(np.int32)
    return matching_face_counts(gids).astype(np.int32)


def shared_faces_taken(world, faces, gids, free, node_id, partners):
    """``free`` (faces found once on this rank) less the faces a rank that shares their
    four nodes has too (collective among the sharers). Only faces free here with all four
    nodes shared with a partner go to that partner, and only they can match what it
    sends."""
    if not partners:
        return free
    candidates, offered = {}, {}
    for rank, idx in partners:
        shared = np.zeros(len(node_id), bool)
        shared[idx] = True
        offered[rank] = np.flatnonzero(free & shared[faces].all(axis=1))
        candidates[rank] = face_rows(gids[offered[rank]])
    received = swap_with(world, [r for r, _ in partners], candidates, tag=81)
    for rank, theirs in received.items():
        mine = offered[rank]
        free[mine[np.isin(candidates[rank], theirs[world.rank])]] = False
    return free


def face_rows(gids):
    """One comparable value per face: its sorted global node ids as 32 raw bytes."""
    keys = np.ascontiguousarray(np.sort(gids, axis=1).astype(np.int64))
    return keys.view(np.dtype((np.void, 32))).ravel()
