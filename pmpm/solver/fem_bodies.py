"""The finite-element bodies of a run as a body kind of the step (seed 004 Sec. 2.3;
``shared/seeds/004_NOTES.md`` Secs. 1.1 and 1.5): explicit central differences on 8-node
hexahedra, velocities at half steps like the grid's.

In each step, from the positions x^k and the velocities v^(k-1/2):

* ``stress_and_forces``: the element stress update and internal plus hourglass forces
  (pmpm.fem.elements), then gravity and loads; the elements' stable rate (1 / step at
  cfl 1, pmpm.fem.stability), as the coarse-grid speed of the same Courant number
  (``speed``);
* ``integrate``: v^(k+1/2) = v^(k-1/2) + dt f / m, then the grid faces' conditions on the
  nodes that lie on them;
* ``move``: x^(k+1) = x^k + dt v^(k+1/2).

The step runs ``stress_and_forces`` and ``integrate`` before the grid's forces are
summed, so that grid coupling (CFEMP, ``pmpm.solver.fem_grid``) can put the nodes' trial
velocities on the grid; it then changes the nodes' velocities by the contact's
correction before ``move``. Over MPI an element belongs to the rank whose slab holds its
centroid; it moves there with its state and its nodes when the decomposition checks its
balance (grid coupling maps each node from the rank whose slab holds the node, whichever
ranks hold its elements, so where elements live changes no answer, only the balance);
the forces of the nodes that several ranks hold are summed over them in rank order
(pmpm.comm.shared_nodes), so every copy of a node moves the same and 1 rank agrees with
N to round-off.
Particle bodies with surface coupling meet them through ICFEMP
(pmpm.solver.surface_contact), which corrects the nodes' velocities and positions after
``move``.
"""
import os
from collections import namedtuple

import numpy as np

from . import observe
from ..comm.shared_nodes import ElementOrderSums, sum_shared_rows
from ..comm.sparse import exchange_arrays
from ..fem.elements import (ASSUMED_STRAIN, FAILED_UPDATE, HOURGLASS_KINDS,
                            NON_POSITIVE_VOLUME, ElementMesh, Hourglass, advance_positions,
                            element_forces, external_forces, lumped_masses)
from ..fem.hexahedron import FACES, boundary_volumes, element_volumes
from ..fem.nodes import advance_and_hold, first_outside, hold_at_faces
from ..fem.stability import element_rates, mesh_rate
from ..kernels.records import BodyMaterials
from ..materials import layout
from ..materials.state import MaterialState, with_later_columns
from .bodies import initial_field
from .energy import load_power_terms
from .errors import SetupError
from .fem_partition import element_owners, partition_mesh, shared_with
from .kinds import BodyKind
from .work_weights import body_weights
from .workspace import Workspace

FAULTS = {NON_POSITIVE_VOLUME: "non-positive volume (inverted or collapsed element)",
          FAILED_UPDATE: "constitutive update failed (NaN, non-convergence or "
                         "non-positive density)"}


class FemBodies(BodyKind):
    """This rank's elements (those whose centroid lies in its slab) and their nodes, of
    every FEM body, concatenated; nodes that elements of other ranks use too are shared
    (their forces are summed over the sharers) and counted by the lowest sharer.

    Parameters
    ----------
    meshes : dict body index -> FemMesh (points, hexes, fixed), the whole meshes
    config : pmpm.case.CaseConfig
    table : solver.bodies.BodyTable
    world : comm.World
    grid, slabs : the coarse grid and its slabs (element ownership at set-up; then
        :meth:`migrate` when the decomposition checks its balance)
    """

    label = "element"
    owns_nodes = rebalances = True

    def __init__(self, meshes, config, table, world, grid, slabs):
        self.take_config(config, table, world)
        whole = WholeMesh(meshes, self.body_indices, table)
        self.whole = whole
        self.n_elements_total = len(whole.hexes)
        owner = element_owners(whole.centroids(), grid, slabs)
        part = partition_mesh(whole.hexes, len(whole.x), owner, world.rank, world.size)
        self.take_part(whole, part)
        self.fixed = whole.fixed[self.node_id].copy()
        self.fixed[self.rigid_nodes()] = False     # a rigid body keeps its velocity
        self.build_state(config)
        self.load, self.load_scale = np.full(len(self.x), -1, np.int32), np.zeros(len(self.x))
        self.force = np.zeros_like(self.x)

    def take_config(self, config, table, world):
        self.table, self.config, self.world = table, config, world
        self.names = table.names
        self.body_indices = [b for b, body in enumerate(config.bodies) if body.is_fem]
        self.h = float(config.grid.cell)
        self.gravity = np.asarray(config.gravity, np.float64)
        self.load_vectors = np.zeros((1, 3))
        self.materials = BodyMaterials(table.codes, table.params, table.rigid)
        self.weight_of_body = body_weights(config, table.rigid)
        self.speed, self.fault = 0.0, None
        self.work, self.kept_rigid_nodes = Workspace(), None
        #: shared nodes' forces summed in element order, as one rank adds them
        self.exact = config.grid.exact_sums
        self.removed_hourglass = 0.0       # of this rank's elements removed from the mesh
        self.rigid_motion = None          # solver.rigid_motion.RigidMotion, set by the run
        self.force_log = None             # solver.forces.ForceLog, set by the simulation
        self.faces = constrained_faces(config.grid)
        self.face_arrays = face_arrays(self.faces)
        self.box = (np.asarray(config.grid.min, np.float64),
                    np.asarray(config.grid.max, np.float64))

    @classmethod
    def from_checkpoint(cls, elements, nodes, config, table, world, grid, slabs):
        """The FEM bodies of a checkpoint (``checkpoint_groups``: every element and every
        node, each once), shared out to the slabs of this run's ranks."""
        fem = cls.__new__(cls)
        fem.take_config(config, table, world)
        order = np.argsort(elements["element_id"], kind="stable")
        elements = with_later_columns({k: col[order] for k, col in elements.items()},
                                      len(order))
        order = np.argsort(nodes["node_id"], kind="stable")
        nodes = {k: col[order] for k, col in nodes.items()}
        fem.first_element = {b: int(np.flatnonzero(elements["body"] == b)[0])
                             for b in fem.body_indices if (elements["body"] == b).any()}
        fem.n_elements_total = int(elements["element_id"].max()) + 1 \
            if len(elements["element_id"]) else 0
        # node ids are 0 .. n-1 until elements are removed (remove_elements) and nodes go
        corners = np.searchsorted(nodes["node_id"], elements["hexes"])
        centroids = nodes["x"][corners].mean(axis=1)
        mine = element_owners(centroids, grid, slabs) == world.rank
        used = np.unique(corners[mine])
        fem.hourglass = Hourglass(*fem.hourglass_forms(config), None, None)
        fem.set_columns({k: col[mine] for k, col in elements.items()},
                        {k: col[used] for k, col in nodes.items()})
        return fem

    def checkpoint_groups(self):
        """This rank's elements and the nodes it counts, as row sets of a checkpoint."""
        nodes = {k: col[self.owned] for k, col in self.node_columns().items()}
        return {"elements": self.element_columns(), "nodes": nodes}

    def hourglass_forms(self, config):
        """Per body the hourglass kind and coefficient (0 for particle bodies)."""
        nb = len(self.names)
        kind, coefficient = np.zeros(nb, np.int64), np.zeros(nb)
        for b in self.body_indices:
            kind[b], coefficient[b] = hourglass_form(config.bodies[b].fem)
        return kind, coefficient

    # -- set-up -------------------------------------------------------------------------
    def take_part(self, whole, part):
        self.element_id, self.node_id = part.elements, part.nodes
        self.partners, self.owned = part.partners, part.owned
        self.order_sums = None
        self.x = np.ascontiguousarray(whole.x[part.nodes])
        self.x0 = self.x.copy()                     # where each node was at the start
        self.hexes = np.ascontiguousarray(part.hexes, np.int64)
        self.rates = np.zeros(len(self.hexes))      # each element's, from the force pass
        self.node_body = whole.node_body[part.nodes]
        self.body = whole.body[part.elements]
        self.vol0 = whole.vol0[part.elements]
        self.mass = whole.mass[part.nodes]
        self.first_element = {b: int(np.flatnonzero(whole.body == b)[0])
                              for b in self.body_indices}

    def build_state(self, config):
        m = len(self.hexes)
        rho0 = self.table.params[self.body, layout.RHO0]
        self.element_mass = rho0 * self.vol0
        self.v = np.zeros_like(self.x)
        temp = np.empty(m)
        centroids = self.centroids()
        for b in self.body_indices:
            body = config.bodies[b]
            nodes, elems = self.node_body == b, self.body == b
            for d, component in enumerate(body.velocity):
                self.v[nodes, d] = initial_field(component, self.x[nodes],
                                                 f"bodies[{b}].velocity[{d}]")
            t_room = self.table.params[b, layout.T_ROOM]
            temp[elems] = initial_field(t_room if body.temperature is None
                                        else body.temperature, centroids[elems],
                                        f"bodies[{b}].temperature")
        self.v[self.fixed] = 0.0                   # the constraints hold from the start
        self.hold_at_faces(None)
        self.state = MaterialState(np.zeros((m, 6)), np.tile(np.eye(3).ravel(), (m, 1)),
                                   rho0.copy(), np.zeros(m), np.zeros(m), temp, np.zeros(m),
                                   np.zeros(m), np.zeros(m))
        self.hourglass = Hourglass(*self.hourglass_forms(config), np.zeros((m, 12)),
                                   np.zeros(m))

    def assign_loads(self, loads, body_names):
        """Mark the nodes each load on an FEM body acts on (on the whole mesh, so every
        rank finds the same); returns problems for loads that select no node. A traction
        gives each selected node a quarter of the area of every free face of its body
        whose four nodes are all selected; a force is shared equally among the selected
        nodes."""
        whole, problems = self.whole, []
        load, scale = np.full(len(whole.x), -1, np.int32), np.zeros(len(whole.x))
        for i, item in enumerate(loads):
            b = body_names.index(item.body)
            if b not in self.body_indices:
                continue
            selected = whole.nodes_in(b, item.region)
            if item.type == "traction":
                area = free_face_areas(whole.x, whole.hexes[whole.body == b], selected)
                selected &= area > 0
                scale[selected] = area[selected]
            elif selected.any():
                scale[selected] = 1.0 / np.count_nonzero(selected)
            if not selected.any():
                problems.append(f"loads[{i}].region: selects no node of FEM body "
                                f"'{item.body}'" + (" on a free face of its mesh"
                                                    if item.type == "traction" else ""))
            load[selected] = i
        self.load, self.load_scale = load[self.node_id], scale[self.node_id]
        return problems

    def forget_whole_mesh(self):
        """Drop the whole mesh once set-up is done: from here on each rank holds only its
        elements and their nodes (the element frames are written from those)."""
        self.whole = None

    # -- migration (seed 004 notes Sec. 4) ---------------------------------------------
    def slab_cells(self, grid, axis):
        """The coarse cell of each element's centroid along ``axis`` (the slabs' balance
        counts elements with the particles)."""
        if not len(self.hexes):
            return np.zeros(0, np.int64)
        cells = grid.cells_of(self.centroids())[:, axis]
        return np.clip(cells, 0, int(grid.n_cells[axis]) - 1)

    def slab_weights(self):
        """What each element weighs in the slabs' balance: its body's cost of an
        element-step in particle-steps (solver.work_weights)."""
        return self.weight_of_body[self.body]

    def migrate(self, grid, slabs):
        """Send every element whose centroid has left this rank's slab to its new owner,
        with its state and its nodes' (collective; one packed sparse exchange of the
        columns, pmpm.comm.sparse, only when some element moves: a message to each rank
        that gets elements). Returns whether any moved."""
        owner = element_owners(self.centroids(), grid, slabs)
        if not self.world.any(np.any(owner != self.world.rank)):
            return False
        elements, nodes = self.element_columns(), self.node_columns()
        packages = []
        for rank in range(self.world.size):
            going = owner == rank
            used = np.unique(self.hexes[going])
            package = {("element", k): col[going] for k, col in elements.items()}
            package.update({("node", k): col[used] for k, col in nodes.items()})
            packages.append(package)
        received = exchange_arrays(self.world, packages)
        elements = {k: np.concatenate([p["element", k] for p in received]) for k in elements}
        nodes = {k: np.concatenate([p["node", k] for p in received]) for k in nodes}
        _, first = np.unique(nodes["node_id"], return_index=True)  # copies are equal
        self.set_columns(elements, {k: col[first] for k, col in nodes.items()})
        self.elements_changed()
        return True

    def element_columns(self):
        columns = {"element_id": self.element_id, "body": self.body, "vol0": self.vol0,
                   "element_mass": self.element_mass, "hexes": self.node_id[self.hexes],
                   "resist": self.hourglass.resist, "hg_energy": self.hourglass.energy}
        columns.update(self.state._asdict())
        return columns

    def node_columns(self):
        return {"node_id": self.node_id, "x": self.x, "x0": self.x0, "v": self.v,
                "mass": self.mass,
                "fixed": self.fixed, "load": self.load, "load_scale": self.load_scale,
                "node_body": self.node_body}

    def set_columns(self, elements, nodes):
        """Take the elements and nodes this rank now holds (any order; kept sorted by
        global id), and find again the nodes it shares."""
        if "x0" not in nodes:                       # checkpoints before displacements
            nodes = dict(nodes, x0=nodes["x"])
        for name, column in in_id_order(nodes, "node_id").items():
            setattr(self, name, column)
        e = in_id_order(elements, "element_id")
        self.element_id, self.body = e["element_id"], e["body"]
        self.vol0, self.element_mass = e["vol0"], e["element_mass"]
        self.hexes = local_indices(self.node_id, e["hexes"])
        self.rates = np.zeros(len(self.hexes))      # until the next force pass
        self.state = MaterialState(*(e[name] for name in MaterialState._fields))
        self.hourglass = self.hourglass._replace(resist=e["resist"], energy=e["hg_energy"])
        self.partners, self.owned = shared_with(self.world, self.node_id, self.x,
                                                 1e-6 * self.h)
        self.order_sums = None
        self.force = np.zeros_like(self.x)

    # -- elements that leave the mesh: what a transfer's rule reads, and the removal ----
    def volumes(self):
        """The elements' current volumes (from their faces: a third of the cost of the
        mean gradient's, the same to round-off; pmpm.fem.hexahedron.boundary_volumes)."""
        out = np.empty(len(self.hexes))
        boundary_volumes(self.x, self.hexes, out)
        return out

    def step_rates(self):
        """Each element's stable rate (1 / its step at cfl 1) from the last force pass
        (0 before the first one after the elements changed)."""
        return self.rates

    def shape_rates(self, initial=False):
        """Per element its stable rate at rest with its material's initial density and
        wave speed, at the current positions (``initial``: at the nodes' initial ones)."""
        x = self.x0 if initial else self.x
        return rates_at_rest(self.table, x, self.hexes, self.body, self.hourglass.kind,
                           self.hourglass.coefficient)

    def mass_shares(self, chosen):
        """(element ids, node ids (m, 8), m_e / 8) of the elements ``chosen`` (bool)."""
        return (self.element_id[chosen], self.node_id[self.hexes[chosen]],
                self.element_mass[chosen] / 8.0)

    def remove_elements(self, chosen):
        """Take this rank's elements ``chosen`` (bool) out of the mesh, for any transfer
        that moves their material elsewhere (collective): every rank's removed elements'
        shares of their nodes' masses, gathered and taken off in element id order (so
        every copy of a shared node, and 1 rank against N, agree); the nodes no element
        here uses any more go, the sharers (halos) are found again, and the kind raises
        :meth:`elements_changed` (the couplings' free faces). The removed elements'
        hourglass energy stays counted (``removed_hourglass``)."""
        shares = merge_shares(self.world.allgather(self.mass_shares(chosen)))
        self.removed_hourglass += float(self.hourglass.energy[chosen].sum())
        _, node_ids, share = shares
        held = np.searchsorted(self.node_id, node_ids.ravel())
        held = np.minimum(held, len(self.node_id) - 1)
        here = self.node_id[held] == node_ids.ravel() if len(self.node_id) else \
            np.zeros(node_ids.size, bool)
        np.subtract.at(self.mass, held[here], np.repeat(share, 8)[here])
        keep = ~chosen
        # for the couplings' free faces: what this change removed (pmpm.solver.surface_
        # contact.local_face_counts updates the faces' counts from it)
        self.last_removal = (self.mesh_version, keep,
                             self.node_id[self.hexes[chosen][:, FACES]].reshape(-1, 4))
        elements = {k: col[keep] for k, col in self.element_columns().items()}
        used = np.zeros(len(self.node_id), bool)
        used[self.hexes[keep].ravel()] = True
        nodes = {k: col[used] for k, col in self.node_columns().items()}
        self.set_columns(elements, nodes)
        self.elements_changed()

    def kinetic_energy_of_nodes(self):
        m, v = self.mass[self.owned], self.v[self.owned]
        return 0.5 * float(m @ np.einsum("ij,ij->i", v, v))

    # -- records ------------------------------------------------------------------------
    def mesh(self):
        return ElementMesh(self.x, self.v, self.hexes, self.body)

    @property
    def n_elements(self):
        return len(self.hexes)

    # -- phases -------------------------------------------------------------------------
    def stress_and_forces(self, dt):
        """Element stresses and nodal forces, summed over the ranks sharing a node, then
        gravity and loads; ``speed`` = h times the largest stable rate, ``rates`` each
        element's."""
        self.force[:] = 0.0
        self.rates = np.zeros(len(self.hexes))
        exact = self.exact and bool(self.partners)
        plan = self.element_order_sums() if exact else None
        parts = self.contribution_rows(plan.n_rows) if exact else None
        rate, bad, why = element_forces(self.mesh(), self.state, self.materials,
                                        self.hourglass, dt, self.force, self.rates, parts,
                                        plan.row_of if exact else None)
        if exact:
            self.force = plan.total(self.force, parts)
        else:
            self.force = sum_shared_rows(self.world, self.force, self.partners)
        external_forces(self.mass, self.gravity, self.load, self.load_scale,
                        self.load_vectors, self.force)
        if self.materials.rigid.any():
            self.force[self.rigid_nodes()] = 0.0
        self.speed = rate * self.h
        if bad >= 0 and self.fault is None:
            self.note_fault(bad, FAULTS[why])

    def contribution_rows(self, n_rows):
        """Zeroed (n_rows, 8, 3) rows for the nodal forces of the elements on shared
        nodes (the exact sums over them), reused from step to step: a fresh array each
        step cost 1.8 s of 25 in the 2 mm perforation on 2 ranks."""
        return self.work.zeros("contributions", n_rows, 24).reshape(-1, 8, 3)

    def element_order_sums(self):
        """The plan of the exact sums over shared nodes (pmpm.comm.shared_nodes.
        ElementOrderSums), made again, on every rank at once, after the elements or
        their sharers change (:meth:`set_columns`)."""
        if self.order_sums is None:
            self.order_sums = ElementOrderSums(self.world, self.partners, self.hexes,
                                               self.element_id, len(self.x))
        return self.order_sums

    def stiffest_element(self):
        """This rank's element with the largest stable rate of the last force pass (the
        shortest stable step; of equal rates the lowest global id): (rate, global id,
        body, number within its body, centroid), or None without elements or before a
        force pass (pmpm.solver.step_limit)."""
        if not len(self.rates) or not self.rates.max() > 0.0:
            return None
        top = np.flatnonzero(self.rates == self.rates.max())
        e = int(top[np.argmin(self.element_id[top])])
        b = int(self.body[e])
        centroid = self.x[self.hexes[e]].mean(axis=0)
        return (float(self.rates[e]), int(self.element_id[e]), b,
                int(self.element_id[e]) - self.first_element[b], centroid.tolist())

    def rigid_nodes(self):
        """The nodes of rigid FEM bodies (material ``rigid``): they move with their
        initial velocity, as rigid particle bodies do, or in the axes ``rigid.free``
        names with their body's velocity (pmpm.solver.rigid_motion). Kept while the
        nodes stay (asked five times a step: 0.4 ms each over the 1 mm perforation's
        330,000 nodes); not to be written."""
        kept = self.kept_rigid_nodes
        if kept is None or kept[0] is not self.node_body:
            kept = self.kept_rigid_nodes = (self.node_body,
                                            self.materials.rigid[self.node_body])
        return kept[1]

    def advance_nodes(self, dt):
        """Element stresses and nodal forces, then the nodes' trial velocities (before
        the grid's forces are summed: grid coupling puts them on the grid)."""
        self.stress_and_forces(dt)
        self.integrate(dt)

    def integrate(self, dt):
        """v <- v + dt f / m with the constraints and the grid faces' conditions, and
        the reactions of both to the force log, in one pass over the nodes
        (pmpm.fem.nodes.advance_and_hold); then the free rigid bodies."""
        log, movable = self.force_log, ~self.rigid_nodes()
        support, face = (log.support, log.face) if log is not None else (NO_SUMS, NO_SUMS)
        advance_and_hold(self.x, self.v, self.force, self.mass, self.fixed, movable,
                         *self.face_arrays, dt, 1e-9 * self.h, log is not None,
                         self.owned & movable, self.node_body, support, face)
        if self.rigid_motion is not None:          # free rigid bodies: gravity, one V each
            self.rigid_motion.integrate(self, dt)

    def hold_at_faces(self, dt):
        """The grid faces' conditions on every node but a rigid body's (dt None: no
        landing on a face, pmpm.fem.nodes.hold_at_faces)."""
        hold_at_faces(self.x, self.v, ~self.rigid_nodes(), *self.face_arrays,
                      0.0 if dt is None else dt, 1e-9 * self.h)

    def move(self, dt):
        bad = advance_positions(self.x, self.v, dt)
        if bad >= 0 and self.fault is None:
            self.fault = (f"node {int(self.node_id[bad])} of FEM body "
                          f"'{self.names[self.node_body[bad]]}': position is not finite")
        if self.fault is None:
            self.fault = self.left_box()

    def left_box(self):
        """The fault of the first node outside the grid box (beyond a free face: the
        others hold their nodes), or None. FE nodes are not dropped like particles: an
        element without its node would break the mesh."""
        lo, hi = self.box
        tol = 1e-9 * self.h
        n = first_outside(self.x, lo, hi, tol)
        if n < 0:
            return None
        out = (self.x[n] < lo - tol) | (self.x[n] > hi + tol)
        d = int(np.flatnonzero(out)[0])
        face = f"{'xyz'[d]}{'-' if self.x[n, d] < lo[d] else '+'}"
        name = self.names[self.node_body[n]]
        return (f"node {int(self.node_id[n])} of FEM body '{name}' "
                f"has left the grid box through the free face {face} (FE nodes are not "
                f"dropped like particles; grid.lost_mass_fraction does not apply): enlarge "
                f"the grid or make the face slip")

    def note_fault(self, e, what):
        b = int(self.body[e])
        self.fault = (f"element {int(self.element_id[e]) - self.first_element[b]} of FEM "
                      f"body '{self.names[b]}': {what}")

    def initial_speed(self):
        """h / (the elements' stable step at cfl 1) over this rank's elements at the
        start (:func:`pmpm.fem.stability.mesh_rate` with the materials' initial wave
        speeds)."""
        return self.h * start_rate(self.table, self.x, self.hexes, self.body,
                                   self.hourglass.kind, self.hourglass.coefficient)

    # -- observables (shared nodes counted by their lowest sharer) ----------------------
    def energies(self):
        """(kinetic, internal, hourglass) of this rank's nodes and elements."""
        m, v = self.mass[self.owned], self.v[self.owned]
        kinetic = 0.5 * float(m @ np.einsum("ij,ij->i", v, v))
        internal = float(self.element_mass @ self.state.e_int)
        hourglass = float(self.hourglass.energy.sum()) + self.removed_hourglass
        return kinetic, internal, hourglass

    def body_stats(self, world):
        """Per FEM body name, over all ranks (collective): mass, counts, centroid,
        velocity, bbox, energies (the plastic work among them) and failed elements."""
        nb = len(self.names)
        sums, box = np.zeros((nb, 14)), np.full((nb, 6), -np.inf)
        for b in self.body_indices:
            nodes, elems = (self.node_body == b) & self.owned, self.body == b
            m, x, v = self.mass[nodes], self.x[nodes], self.v[nodes]
            sums[b] = [m.sum(), *(m @ x), *(m @ v), elems.sum(), nodes.sum(),
                       0.5 * m @ np.einsum("ij,ij->i", v, v),
                       self.element_mass[elems] @ self.state.e_int[elems],
                       self.hourglass.energy[elems].sum(),
                       self.element_mass[elems] @ self.state.w_p[elems],
                       np.count_nonzero(self.state.damage[elems] >= 1.0)]
            if nodes.any():
                box[b, :3], box[b, 3:] = -x.min(axis=0), x.max(axis=0)
        if self.exact:
            sums = self.exact_body_sums(world)
        else:
            sums = world.sum(sums)
        box = world.max(box)
        return {self.names[b]: body_entry(sums[b], box[b]) for b in self.body_indices}

    def exact_body_sums(self, world):
        """body_stats' sums, exact over the ranks (pmpm.solver.observe)."""
        s, o = self.state, self.owned
        acc = observe.fem_sums_exact(
            len(self.names), (self.node_body[o], self.mass[o], self.x[o], self.v[o]),
            (self.body, self.element_mass, s.e_int, self.hourglass.energy, s.w_p,
             s.damage))
        return observe.exact_totals(world, [acc])[0].reshape(len(self.names), -1)

    def energy_sums(self):
        o = self.owned
        return observe.node_energy_sums(self.mass[o], self.v[o], self.element_mass,
                                        self.state.e_int, self.hourglass.energy,
                                        self.removed_hourglass)

    def potential_sums(self, gravity):
        return observe.potential_sums(self.mass[self.owned], self.x[self.owned], gravity)

    def take_loads(self, vectors):
        self.load_vectors = vectors

    def element_count(self):
        return self.n_elements

    def potential(self, gravity):
        m, x = self.mass[self.owned], self.x[self.owned]
        return -float(m @ (x @ np.asarray(gravity, np.float64)))

    def load_power(self, load_vectors):
        loaded = (self.load >= 0) & self.owned
        if not loaded.any():
            return 0.0
        forces = self.load_scale[loaded, None] * load_vectors[self.load[loaded]]
        return float(np.einsum("ij,ij->", forces, self.v[loaded]))

    def load_power_terms(self, load_vectors):
        o = self.owned
        return load_power_terms(self.load[o], self.load_scale[o], self.v[o], load_vectors)

    def centroids(self):
        return self.x[self.hexes].mean(axis=1)

    def frame(self):
        """The columns of an element frame (pmpm.io.elements_h5) held here: (nodes,
        elements), the nodes this rank counts (``owned``: each node once over the ranks)
        with ``node_id``, and its elements with ``element_id`` and ``hexes`` as global
        node ids; the writer puts them in id order."""
        s = self.state
        nodes = {"node_id": self.node_id[self.owned], "node_x": self.x[self.owned],
                 "node_v": self.v[self.owned],
                 "node_displacement": self.x[self.owned] - self.x0[self.owned]}
        elements = {"element_id": self.element_id, "hexes": self.node_id[self.hexes],
                    "body": self.body, "stress": s.stress, "eps_p": s.eps_p,
                    "density": s.rho, "e_int": s.e_int, "damage": s.damage,
                    "centroid": self.centroids(),
                    "hourglass_energy": self.hourglass.energy}
        return nodes, elements


def merge_shares(parts):
    """Every rank's (element ids, node ids (m, 8), mass shares (m,)) as one set of
    rows, in element id order."""
    ids = np.concatenate([p[0] for p in parts])
    order = np.argsort(ids, kind="stable")
    nodes = np.concatenate([p[1] for p in parts])[order]
    shares = np.concatenate([p[2] for p in parts])[order]
    return ids[order], nodes, shares


class WholeMesh:
    """Every FEM body's mesh, concatenated, with the quantities that need all of it
    (element volumes, lumped nodal masses): built the same on every rank at set-up."""

    def __init__(self, meshes, body_indices, table):
        xs, hexes, node_body, elem_body, fixed, offset = [], [], [], [], [], 0
        for b in body_indices:
            points, cells, held = meshes[b]
            xs.append(points)
            fixed.append(held)
            hexes.append(cells + offset)
            node_body.append(np.full(len(points), b, np.int32))
            elem_body.append(np.full(len(cells), b, np.int32))
            offset += len(points)
        self.x = np.ascontiguousarray(np.concatenate(xs), np.float64)
        self.hexes = np.ascontiguousarray(np.concatenate(hexes), np.int64)
        self.node_body, self.body = np.concatenate(node_body), np.concatenate(elem_body)
        self.fixed = np.concatenate(fixed)
        self.vol0 = np.empty(len(self.hexes))
        element_volumes(self.x, self.hexes, self.vol0)
        self.mass = np.empty(len(self.x))
        lumped_masses(self.hexes, self.vol0, table.params[self.body, layout.RHO0],
                      self.mass)

    def load_power_terms(self, load_vectors):
        o = self.owned
        return load_power_terms(self.load[o], self.load_scale[o], self.v[o], load_vectors)

    def centroids(self):
        return self.x[self.hexes].mean(axis=1)

    def nodes_in(self, b, region):
        lo, hi = np.asarray(region.min), np.asarray(region.max)
        return np.all((self.x >= lo) & (self.x <= hi), axis=1) & (self.node_body == b)


def body_entry(sums, box):
    """One FEM body's summary entry from its summed moments and bounding box."""
    mass = sums[0]
    safe = mass if mass > 0 else 1.0
    return {"mass": float(mass), "n_particles": 0, "n_elements": int(sums[7]),
            "n_nodes": int(sums[8]), "centroid": (sums[1:4] / safe).tolist(),
            "velocity": (sums[4:7] / safe).tolist(), "bbox_min": (-box[:3]).tolist(),
            "bbox_max": box[3:].tolist(),
            "energy": {"kinetic": float(sums[9]), "internal": float(sums[10]),
                       "hourglass": float(sums[11]), "plastic": float(sums[12])},
            "n_failed": int(sums[13])}


def constrained_faces(grid):
    """The grid box's faces that hold nodes: (axis, side -1 (min) or +1 (max), plane,
    whether it is fixed (else slip or symmetry))."""
    faces = []
    for d in range(3):
        for side, plane in ((-1, grid.min[d]), (1, grid.max[d])):
            kind = grid.boundary[f"{'xyz'[d]}{'-' if side < 0 else '+'}"]
            if kind in ("fixed", "slip", "symmetry"):
                faces.append((d, side, float(plane), kind == "fixed"))
    return faces


def face_arrays(faces):
    """The constrained faces as the parallel arrays of pmpm.fem.nodes: (axis, side,
    plane, fixed)."""
    return (np.array([f[0] for f in faces], np.int64),
            np.array([float(f[1]) for f in faces], np.float64),
            np.array([f[2] for f in faces], np.float64),
            np.array([f[3] for f in faces], np.bool_))


#: the force log's sums when there is none (advance_and_hold then adds nothing)
NO_SUMS = np.zeros((0, 3))


def free_face_areas(x, hexes, selected):
    """Per node, a quarter of the area of each free face (a face of one element only)
    whose four nodes are all ``selected``."""
    faces = hexes[:, FACES].reshape(-1, 4)
    keys = np.sort(faces, axis=1)
    _, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    free = faces[first[counts == 1]]
    free = free[selected[free].all(axis=1)]
    p = x[free]
    normal = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    area = 0.5 * np.linalg.norm(normal, axis=1)
    out = np.zeros(len(x))
    np.add.at(out, free.ravel(), np.repeat(area / 4.0, 4))
    return out


#: One FEM body's mesh: ``points`` (n, 3), ``hexes`` (m, 8) and ``fixed`` (n, 3) bool,
#: the velocity components its ``fem.constraints`` hold at zero.
FemMesh = namedtuple("FemMesh", "points hexes fixed")


def build_meshes(config, case_dir):
    """{body index: FemMesh} of the case's FEM bodies; SetupError naming the key of a mesh
    that cannot be built or a constraint that selects no node."""
    from ..case.hexmesh import InvertedElementError, MixedMeshError, hex_mesh
    from ..case.mesh import MeshReadError
    meshes = {}
    for b, body in enumerate(config.bodies):
        if not body.is_fem:
            continue
        try:
            points, hexes = hex_mesh(body.geometry, body.fem.element_size, case_dir)
            fixed = constrained(points, body, case_dir, f"bodies[{b}].fem.constraints")
        except (MeshReadError, InvertedElementError, MixedMeshError) as error:
            raise SetupError([f"bodies[{b}].geometry: {error}"]) from None
        meshes[b] = FemMesh(points, hexes, fixed)
    refuse_friction_faces(meshes, config.grid)
    return meshes


def refuse_friction_faces(meshes, grid):
    """SetupError naming ``grid.friction.FACE`` when FEM nodes lie on a slip face with
    friction: they would take it as frictionless slip (the wall rule of pmpm.kernels.
    boundary is not applied to FE nodes yet)."""
    friction = getattr(grid, "friction", None) or {}
    for d in range(3):
        for face, plane in ((f"{'xyz'[d]}-", grid.min[d]), (f"{'xyz'[d]}+", grid.max[d])):
            if friction.get(face, 0.0) > 0 and any(
                    (np.abs(m.points[:, d] - plane) <= 1e-9 * grid.cell).any()
                    for m in meshes.values()):
                raise SetupError([f"grid.friction.{face}: nodes of an FEM body lie on this "
                                  f"face; FE nodes take no friction yet (only frictionless "
                                  f"slip): set it to 0 or keep FEM bodies off the face"])


def constrained(points, body, case_dir, key):
    """(n, 3) bool: the components each of ``body``'s constraints holds at zero."""
    from ..case.hexmesh import read_node_sets
    fixed = np.zeros(points.shape, bool)
    items = body.fem.constraints
    sets = read_node_sets(os.path.join(case_dir, body.geometry["file"])) \
        if any(c.node_set is not None for c in items) else {}
    for j, item in enumerate(items):
        if item.node_set is not None:
            chosen = np.zeros(len(points), bool)
            chosen[sets[item.node_set]] = True
        else:
            lo, hi = np.asarray(item.region["min"]), np.asarray(item.region["max"])
            chosen = np.all((points >= lo) & (points <= hi), axis=1)
        if not chosen.any():
            raise SetupError([f"{key}[{j}]: selects no node of body '{body.name}'"])
        for axis in item.fix:
            fixed[chosen, "xyz".index(axis)] = True
    return fixed


def hourglass_form(fem):
    """(kind, coefficient) of an FEM body's ``fem`` (pmpm.case.FemConfig): the reduced
    element's hourglass form and coefficient, or ASSUMED_STRAIN (and 0: its stiffness
    comes from the material) for ``element: assumed_strain``."""
    if fem.element == "assumed_strain":
        return ASSUMED_STRAIN, 0.0
    return HOURGLASS_KINDS[fem.hourglass], fem.hourglass_coefficient


def start_rate(table, x, hexes, body, hg_kind, hg_k):
    """The largest stable rate (1 / step at cfl 1) of the elements ``hexes`` at rest with
    their materials' initial densities and wave speeds (rigid bodies: none)."""
    rho0, speeds = initial_waves(table)
    return mesh_rate(x, np.asarray(hexes, np.int64), np.asarray(body, np.int32), rho0,
                     speeds, table.params, np.asarray(hg_kind, np.int64),
                     np.asarray(hg_k, np.float64))


def rates_at_rest(table, x, hexes, body, hg_kind, hg_k):
    """Per element of ``hexes`` the stable rate at rest with its material's initial
    density and wave speed: a measure of its shape (0 for rigid bodies, inf where
    inverted; pmpm.fem.stability.element_rates)."""
    rho0, speeds = initial_waves(table)
    out = np.empty(len(hexes))
    element_rates(x, np.asarray(hexes, np.int64), np.asarray(body, np.int32), rho0, speeds,
                  table.params, np.asarray(hg_kind, np.int64), np.asarray(hg_k, np.float64),
                  out)
    return out


def initial_waves(table):
    """(rho0, c0) per body of the material table (c0 = 0 for rigid bodies)."""
    nb = len(table.names)
    speeds = np.array([0.0 if table.rigid[b] else table.initial_wave_speed(b)
                       for b in range(nb)])
    return np.ascontiguousarray(table.params[:, layout.RHO0]), speeds


def in_id_order(columns, id_name):
    """``columns`` (a dict of arrays) sorted by ``columns[id_name]`` (stable), each
    contiguous. Removal keeps the order, so there the sort, and the copy of every
    column it takes (a fifth of a second at 314,600 elements), is skipped."""
    ids = columns[id_name]
    if len(ids) < 2 or bool(np.all(ids[1:] > ids[:-1])):
        return {k: np.ascontiguousarray(col) for k, col in columns.items()}
    order = np.argsort(ids, kind="stable")
    return {k: np.ascontiguousarray(col[order]) for k, col in columns.items()}


def local_indices(node_id, global_ids):
    """The local index of each of ``global_ids`` (int64) in the ascending ``node_id``:
    a table over the ids' range where it is not much larger than the node count (one
    gather), a binary search otherwise."""
    if len(node_id) and node_id[-1] - node_id[0] < 4 * len(node_id) + 1024:
        table = np.zeros(int(node_id[-1] - node_id[0]) + 1, np.int64)
        table[node_id - node_id[0]] = np.arange(len(node_id), dtype=np.int64)
        return table[np.asarray(global_ids) - node_id[0]]
    return np.searchsorted(node_id, global_ids).astype(np.int64)
