"""The finite-element bodies of a run as a body kind of the step (seed 004 Sec. 2.3;
``shared/seeds/004_NOTES.md`` Secs. 1.1 and 1.5): explicit central differences on 8-node
hexahedra, velocities at half steps like the grid's.

In each step, from the positions x^k and the velocities v^(k-1/2):

* ``stress_and_forces``: the element stress update and internal plus hourglass forces
  (pmpm.fem.elements), then gravity and loads; the stable element rate c / L_e, as the
  coarse-grid speed of the same Courant number (``speed``);
* ``integrate``: v^(k+1/2) = v^(k-1/2) + dt f / m, then the grid faces' conditions on the
  nodes that lie on them;
* ``move``: x^(k+1) = x^k + dt v^(k+1/2).

No coupling to particles yet (CFEMP, ICFEMP); every element and node lives on the one
rank a run with FEM bodies has for now.
"""
import numpy as np

from ..fem.elements import (FAILED_UPDATE, HOURGLASS_KINDS, NON_POSITIVE_VOLUME,
                            ElementMesh, Hourglass, advance_positions, advance_velocities,
                            element_forces, external_forces, lumped_masses)
from ..fem.hexahedron import FACES, element_geometry, element_volumes
from ..kernels.records import BodyMaterials
from ..materials import layout
from ..materials.state import MaterialState
from .bodies import initial_field
from .errors import SetupError

FAULTS = {NON_POSITIVE_VOLUME: "non-positive volume (inverted or collapsed element)",
          FAILED_UPDATE: "constitutive update failed (NaN, non-convergence or "
                         "non-positive density)"}


class FemBodies:
    """The nodes and elements of every FEM body, concatenated.

    Parameters
    ----------
    meshes : dict body index -> (points (n, 3), hexes (m, 8))
    config : pmpm.case.CaseConfig
    table : solver.bodies.BodyTable
    """

    label = "element"

    def __init__(self, meshes, config, table):
        self.table, self.config = table, config
        self.names = table.names
        self.body_indices = sorted(meshes)
        self.h = float(config.grid.cell)
        self.gravity = np.asarray(config.gravity, np.float64)
        self.load_vectors = np.zeros((1, 3))
        self.materials = BodyMaterials(table.codes, table.params, table.rigid)
        self.build_mesh(meshes)
        self.build_state(config)
        self.fixed = face_constraints(self.x, config.grid)
        self.load, self.load_scale = np.full(len(self.x), -1, np.int32), np.zeros(len(self.x))
        self.force = np.zeros_like(self.x)
        self.speed, self.fault = 0.0, None

    # -- set-up -------------------------------------------------------------------------
    def build_mesh(self, meshes):
        xs, hexes, node_body, elem_body, offset = [], [], [], [], 0
        for b in self.body_indices:
            points, cells = meshes[b]
            xs.append(points)
            hexes.append(cells + offset)
            node_body.append(np.full(len(points), b, np.int32))
            elem_body.append(np.full(len(cells), b, np.int32))
            offset += len(points)
        self.x = np.ascontiguousarray(np.concatenate(xs), np.float64)
        self.hexes = np.ascontiguousarray(np.concatenate(hexes), np.int64)
        self.node_body = np.concatenate(node_body)
        self.body = np.concatenate(elem_body)

    def build_state(self, config):
        m = len(self.hexes)
        rho0 = self.table.params[self.body, layout.RHO0]
        self.vol0 = np.empty(m)
        element_volumes(self.x, self.hexes, self.vol0)
        self.element_mass = rho0 * self.vol0
        self.mass = np.empty(len(self.x))
        lumped_masses(self.hexes, self.vol0, rho0, self.mass)
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
        self.state = MaterialState(np.zeros((m, 6)), np.tile(np.eye(3).ravel(), (m, 1)),
                                   rho0.copy(), np.zeros(m), np.zeros(m), temp, np.zeros(m))
        nb = len(self.names)
        kind, coefficient = np.zeros(nb, np.int64), np.zeros(nb)
        for b in self.body_indices:
            fem = config.bodies[b].fem
            kind[b] = HOURGLASS_KINDS[fem["hourglass"]]
            coefficient[b] = fem["hourglass_coefficient"]
        self.hourglass = Hourglass(kind, coefficient, np.zeros((m, 12)), np.zeros(m))

    def assign_loads(self, loads, body_names):
        """Mark the nodes each load on an FEM body acts on; returns problems for loads that
        select no node. A traction gives each selected node a quarter of the area of every
        free face of its body whose four nodes are all selected; a force is shared
        equally among the selected nodes."""
        problems = []
        for i, load in enumerate(loads):
            b = body_names.index(load.body)
            if b not in self.body_indices:
                continue
            selected = self.nodes_in(b, load.region)
            if load.type == "traction":
                area = free_face_areas(self.x, self.hexes[self.body == b], selected)
                selected &= area > 0
                self.load_scale[selected] = area[selected]
            elif selected.any():
                self.load_scale[selected] = 1.0 / np.count_nonzero(selected)
            if not selected.any():
                problems.append(f"loads[{i}].region: selects no node of FEM body "
                                f"'{load.body}'" + (" on a free face of its mesh"
                                                    if load.type == "traction" else ""))
            self.load[selected] = i
        return problems

    def nodes_in(self, b, region):
        lo, hi = np.asarray(region.min), np.asarray(region.max)
        return np.all((self.x >= lo) & (self.x <= hi), axis=1) & (self.node_body == b)

    # -- records ------------------------------------------------------------------------
    def mesh(self):
        return ElementMesh(self.x, self.v, self.hexes, self.body)

    @property
    def n_elements(self):
        return len(self.hexes)

    # -- phases -------------------------------------------------------------------------
    def stress_and_forces(self, dt):
        """Element stresses and nodal forces; ``speed`` = h c / L_e, the largest."""
        self.force[:] = 0.0
        rate, bad, why = element_forces(self.mesh(), self.state, self.materials,
                                        self.hourglass, dt, self.force)
        external_forces(self.mass, self.gravity, self.load, self.load_scale,
                        self.load_vectors, self.force)
        self.speed = rate * self.h
        if bad >= 0 and self.fault is None:
            self.note_fault(bad, FAULTS[why])

    def integrate(self, dt):
        advance_velocities(self.v, self.force, self.mass, self.fixed, dt)

    def move(self, dt):
        bad = advance_positions(self.x, self.v, dt)
        if bad >= 0 and self.fault is None:
            self.fault = (f"node {bad} of FEM body '{self.names[self.node_body[bad]]}': "
                          f"position is not finite")

    def note_fault(self, e, what):
        first = np.flatnonzero(self.body == self.body[e])[0]
        self.fault = (f"element {e - first} of FEM body '{self.names[self.body[e]]}': "
                      f"{what}")

    def initial_speed(self):
        """h c0 / L_e over the elements at the start (c0 the material's wave speed)."""
        b = np.empty((8, 3))
        fastest = 0.0
        speeds = [self.table.initial_wave_speed(i) for i in range(len(self.names))]
        for e in range(len(self.hexes)):
            volume, area = element_geometry(self.x[self.hexes[e]], b)
            fastest = max(fastest, speeds[self.body[e]] * area / volume)
        return fastest * self.h

    # -- observables --------------------------------------------------------------------
    def energies(self):
        """(kinetic, internal, hourglass) of this rank's nodes and elements."""
        kinetic = 0.5 * float(self.mass @ np.einsum("ij,ij->i", self.v, self.v))
        internal = float(self.element_mass @ self.state.e_int)
        return kinetic, internal, float(self.hourglass.energy.sum())

    def body_stats(self):
        """Per FEM body name: mass, counts, centroid, velocity, bbox and energies."""
        stats = {}
        for b in self.body_indices:
            nodes, elems = self.node_body == b, self.body == b
            m = self.mass[nodes]
            x, v = self.x[nodes], self.v[nodes]
            total = float(m.sum())
            stats[self.names[b]] = {
                "mass": total, "n_particles": 0, "n_elements": int(elems.sum()),
                "n_nodes": int(nodes.sum()), "centroid": (m @ x / total).tolist(),
                "velocity": (m @ v / total).tolist(), "bbox_min": x.min(axis=0).tolist(),
                "bbox_max": x.max(axis=0).tolist(),
                "energy": {"kinetic": 0.5 * float(m @ np.einsum("ij,ij->i", v, v)),
                           "internal": float(self.element_mass[elems]
                                             @ self.state.e_int[elems]),
                           "hourglass": float(self.hourglass.energy[elems].sum())}}
        return stats

    def potential(self, gravity):
        return -float(self.mass @ (self.x @ np.asarray(gravity, np.float64)))

    def load_power(self, load_vectors):
        loaded = self.load >= 0
        if not loaded.any():
            return 0.0
        forces = self.load_scale[loaded, None] * load_vectors[self.load[loaded]]
        return float(np.einsum("ij,ij->", forces, self.v[loaded]))

    def centroids(self):
        return self.x[self.hexes].mean(axis=1)

    def frame(self):
        """The columns of an element frame (pmpm.io.elements_h5)."""
        s = self.state
        return {"node_x": self.x, "node_v": self.v, "stress": s.stress, "eps_p": s.eps_p,
                "density": s.rho, "e_int": s.e_int, "centroid": self.centroids(),
                "hourglass_energy": self.hourglass.energy}


def face_constraints(x, grid):
    """(n, 3) bool: the velocity components held at zero at nodes on a grid face (within
    1e-9 cells): every component on a fixed face, the normal one on a slip or symmetry
    face."""
    fixed = np.zeros(x.shape, bool)
    tol = 1e-9 * grid.cell
    for d in range(3):
        for face, plane in ((f"{'xyz'[d]}-", grid.min[d]), (f"{'xyz'[d]}+", grid.max[d])):
            on = np.abs(x[:, d] - plane) <= tol
            kind = grid.boundary[face]
            if kind == "fixed":
                fixed[on] = True
            elif kind in ("slip", "symmetry"):
                fixed[on, d] = True
    return fixed


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


def build_meshes(config, case_dir):
    """{body index: (points, hexes)} of the case's FEM bodies; SetupError naming the key
    of a mesh that cannot be built (the case check has normally caught it already)."""
    from ..case.hexmesh import InvertedElementError, hex_mesh
    from ..case.mesh import MeshReadError
    meshes = {}
    for b, body in enumerate(config.bodies):
        if body.method != "fem":
            continue
        try:
            meshes[b] = hex_mesh(body.geometry, body.fem["element_size"], case_dir)
        except (MeshReadError, InvertedElementError) as error:
            raise SetupError([f"bodies[{b}].geometry: {error}"]) from None
    return meshes
