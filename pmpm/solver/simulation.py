"""Build the initial state of a run from a validated case, or from a checkpoint, and
what the run loop asks of it."""
import numpy as np

from ..comm.slabs import Slabs, choose_slabs
from ..grid import CoarseGrid, Level, Window
from ..kernels.shape import HALO, SHAPE_CODES
from ..particles import particle_store
from .bodies import BodyTable, assign_loads, build_particles, fill_positions
from .contact import ContactRules
from .decomposition import Decomposition, slab_min_width
from .errors import SetupError
from .fem_bodies import build_meshes
from .observe import exact_totals
from .levels import Hierarchy
from .particle_bodies import ParticleBodies
from .refine import Refiner
from .registry import (KIND, KINDS, PARTS, TRANSFER, Setup, build_parts, initial_kinds,
                       restored_kinds)
from .schemes import make_scheme
from .step import Stepper
from .rigid_motion import RigidMotion
from .work_weights import body_weights


class Simulation:
    """Everything one rank needs to step a case: grid, decomposition, body kinds,
    couplings, and the stepper that runs them."""

    def __init__(self, world, config, grid, slabs, particles, bodies, id_base=None,
                 kinds=None):
        """``particles``: the particle store; ``kinds``: {name: kind} of the kinds beyond
        the particles (solver.registry.KINDS), each an attribute (None: no body of its
        method): ``elements``, the FEM bodies (solver.fem_bodies.FemBodies)."""
        self.world, self.config, self.grid = world, config, grid
        self.bodies = bodies
        kinds = kinds or {}
        for entry in KINDS:
            setattr(self, entry.name, kinds.get(entry.name))
        elements = self.elements
        if elements:
            motion = RigidMotion(config, elements, world)
            elements.rigid_motion = motion if motion.active else None
        n_total = max(world.sum(particles.n), 1)
        mean_mass = world.sum(float(particles.mass.sum())) / n_total
        if mean_mass == 0 and elements:          # FEM bodies only (particles may come)
            mean_mass = world.sum(float(elements.element_mass.sum())) / max(
                elements.n_elements_total, 1)
        m_tiny = 1e-12 * mean_mass
        self.windows = make_windows(config.grid, grid, bodies.names)
        shape = SHAPE_CODES[config.grid.shape_functions]
        # a window's block reaches one coarse node layer (ratio of its own) beyond its
        # particles' cells, so that a rank holds the window node of every coarse node it
        # holds that is tied to one (pmpm.kernels.tied.find_inner_ties)
        levels = [Level(grid, w, HALO[shape] * (w.ratio if w else 1))
                  for w in [None] + self.windows]
        self.grids = Hierarchy(levels, world, shape, bodies.half_width)
        self.points = ParticleBodies(particles, bodies, config.gravity, config.time.pic,
                                     config.time.transfer)
        self.kinds = [self.points]
        self.decomposition = Decomposition(world, grid, slabs, self.grids, self.windows,
                                           len(bodies.names), config.grid.exact_sums)
        rules = ContactRules(config.contact, bodies,
                             [b.is_fem for b in config.bodies])
        setup = Setup(world, config, grid, bodies, self.points, elements, self.decomposition,
                      rules, self.windows, len(self.grids.states), m_tiny, n_total)
        self.parts = build_parts(setup, PARTS)
        for entry in PARTS:               # each part is an attribute (None: not asked for)
            setattr(self, entry.name, self.parts.get(entry.name))
        transfers = self.parts_of(TRANSFER)
        if id_base is None:               # split particles' ids above every transfer's
            id_base = n_total + sum(t.reserved_ids for t in transfers)
        self.refiner = Refiner(world, grid, self.windows, self.kinds, id_base,
                               slabs.axis if config.grid.exact_sums else None)
        #: every body kind, in the order their parts are summed (solver.kinds)
        self.all_kinds = [self.points] + [kinds[e.name] for e in KINDS if e.name in kinds] \
            + self.parts_of(KIND)
        for kind in self.all_kinds:       # the couplings follow the kinds' meshes
            for coupling in setup.couplings:
                kind.when_elements_change(coupling.after_elements_changed)
        exact = config.grid.exact_sums
        for level in self.grids:  # windows: solver.couplings; grid-coupled FE nodes:
            level.exact = exact   # solver.fem_grid
        self.points.exact = self.exact = exact
        self.stepper = Stepper(self.decomposition, self.grids, self.all_kinds,
                               setup.couplings, make_scheme(config.time.scheme),
                               self.refiner, m_tiny, transfers)
        self.decomposition.update_cell_ranges(self.kinds)
        self.loads = config.loads
        self.time, self.step_count = 0.0, 0

    def parts_of(self, role):
        """The parts of ``role`` (solver.registry), in registry order."""
        return [self.parts[e.name] for e in PARTS if e.role == role and e.name in self.parts]

    @property
    def particles(self):
        return self.points.particles

    @property
    def slabs(self):
        return self.decomposition.slabs

    @classmethod
    def from_config(cls, world, config, case_dir, fill_body):
        """The initial state of a ``pmpm.case.CaseConfig`` (``case_dir``: where mesh
        files are looked up)."""
        return cls.from_layout(world, config, cls.lay_out(world, config, case_dir, fill_body))

    @staticmethod
    def lay_out(world, config, case_dir, fill_body):
        """The bodies' positions and the slab decomposition, before any kernel is
        compiled: a decomposition that cannot be made fails here, in a second."""
        grid = CoarseGrid.from_config(config.grid)
        filled = fill_positions(config, fill_body, case_dir)
        x = np.concatenate([positions for positions, _ in filled])
        meshes = build_meshes(config, case_dir)
        counts = initial_histograms(config, grid, x, meshes)
        slabs = choose_slabs(counts, world.size, config.decomposition.axis,
                             slab_min_width(SHAPE_CODES[config.grid.shape_functions]),
                             config.grid.exact_sums)
        mine = slabs.owner_of_cells(grid.cells_of(x)[:, slabs.axis]) == world.rank
        return grid, filled, slabs, mine, meshes

    @classmethod
    def from_layout(cls, world, config, layout):
        """The initial state from what ``lay_out`` returned."""
        grid, filled, slabs, mine, meshes = layout
        bodies = BodyTable(config)
        particles = build_on_every_rank(world, lambda: build_particles(config, bodies, filled,
                                                                       mine))
        problems = assign_loads(config, particles, world.sum)
        kinds, more = initial_kinds(world, config, bodies, grid, slabs, meshes)
        if problems + more:
            raise SetupError(problems + more)
        return cls(world, config, grid, slabs, particles, bodies, kinds=kinds)

    @classmethod
    def from_checkpoint(cls, world, config, scalars, columns, groups=None):
        """The state of a checkpoint (``groups``: its FEM ``elements`` and ``nodes``, whole,
        when the case has FEM bodies)."""
        grid = CoarseGrid.from_config(config.grid)
        bodies = BodyTable(config)
        particles = particle_store(config.time.transfer == "apic")(columns)
        slabs = Slabs(scalars["slab_axis"], scalars["slab_bounds"])
        if len(slabs.bounds) != world.size + 1:
            counts = checkpoint_histograms(world, config, grid, bodies, particles, groups)
            slabs = choose_slabs(counts, world.size, "xyz"[scalars["slab_axis"]],
                                 slab_min_width(SHAPE_CODES[config.grid.shape_functions]))
        refined = scalars.get("refine")
        kinds = restored_kinds(world, config, bodies, grid, slabs, groups)
        sim = cls(world, config, grid, slabs, particles, bodies,
                  refined["id_base"] if refined else None, kinds=kinds)
        if refined:
            sim.refiner.restore(refined)
        for entry in PARTS:
            if entry.kept and entry.name in sim.parts and scalars.get(entry.kept.key):
                entry.kept.load(sim.parts[entry.name], scalars[entry.kept.key])
        sim.decomposition.send_to_owners(sim.kinds)
        sim.decomposition.update_cell_ranges(sim.kinds)
        sim.time, sim.step_count = scalars["time"], scalars["step"]
        sim.stepper.fastest = scalars["fastest"]
        sim.decomposition.lost = scalars.get("lost", 0)
        for name in ("lost_count", "lost_mass"):
            if name in scalars:
                getattr(sim.decomposition, name)[:] = scalars[name]
        return sim

    # -- what the run loop asks --------------------------------------------------------
    def advance(self, dt):
        """One step of ``dt`` from ``time``, the loads at the step's mid-time."""
        vectors = self.load_vectors(self.time + 0.5 * dt)
        for kind in self.all_kinds:
            kind.take_loads(vectors)
        self.stepper.step(dt)
        self.time += dt
        self.step_count += 1

    def fastest_speed(self):
        """The fastest wave plus point speed of the last step, as the speed that gives
        the same Courant number on the coarse grid (before the first step: the initial
        one)."""
        fastest = self.stepper.fastest
        if self.step_count > 0 or fastest > 0:
            return fastest
        return self.initial_speed()

    @property
    def lost(self):
        return self.decomposition.lost

    def sort_by_cell(self):
        for kind in self.kinds:
            kind.sort_by_cell(self.grid, self.slabs.axis)

    def rebalance(self, threshold):
        """Rebalance the slabs; FEM elements whose centroid left their rank's slab
        migrate (and their kind tells the couplings, ``elements_changed``)."""
        result = self.decomposition.rebalance(threshold, self.kinds, self.rebalancing())
        for kind in self.rebalancing():
            kind.migrate(self.grid, self.slabs)
        return result

    def rebalancing(self):
        """The kinds that move to the new slabs when they are rebalanced (elements)."""
        return [kind for kind in self.all_kinds if kind.rebalances]

    def imbalance(self):
        """The weighted imbalance of the slabs now: max/mean - 1 over the ranks of the
        particles plus the elements' weights each slab holds (collective)."""
        return self.decomposition.imbalance(self.kinds + self.rebalancing())

    def restart_state(self):
        """What a checkpoint keeps beyond the points' columns (collective: the deepest
        centres and nodes of the contacts are reduced over the ranks)."""
        return {"slab_axis": self.slabs.axis, "slab_bounds": self.slabs.bounds.tolist(),
                "fastest": self.stepper.fastest, "lost": int(self.lost),
                "lost_count": self.decomposition.lost_count.tolist(),
                "lost_mass": self.decomposition.lost_mass.tolist(),
                "refine": self.refiner.state(), **self.parts_state()}

    def parts_state(self):
        """The checkpoint's scalars of the registry's parts that it keeps (collective)."""
        return {e.kept.key: e.kept.save(self.parts[e.name]) if e.name in self.parts
                else e.kept.absent for e in PARTS if e.kept}

    def checkpoint_groups(self):
        """The row sets a checkpoint keeps beside the particles (FEM bodies), or None."""
        return self.elements.checkpoint_groups() if self.elements else None

    def window_counts(self):
        """Points on each grid level, over all ranks (0: the coarse grid)."""
        self.decomposition.assign_levels(self.kinds)
        local = sum(np.bincount(k.level_of, minlength=len(self.grids.states))
                    for k in self.kinds)
        return self.world.sum(local)

    def initial_speed(self):
        """Largest initial wave speed plus particle speed, over all ranks."""
        p = self.particles
        c = np.array([self.bodies.initial_wave_speed(b) for b in range(len(self.bodies.names))])
        speeds = c[p.body] + np.linalg.norm(p.v, axis=1) if p.n else np.zeros(1)
        finest = max([w.ratio for w in self.windows] + [1])
        elements = self.elements.initial_speed() if self.elements else 0.0
        return max(self.world.max(float(speeds.max())) * finest, self.world.max(elements))

    # -- what the outputs ask, over every body kind ------------------------------------
    def contact_summary(self):
        """With particle-to-surface contact ``surface_contact.largest_penetration``, the
        deepest any particle centre was found behind the face of its pair; with
        node-to-surface contact ``node_contact.largest_penetration``, the deepest any FE
        node was found behind a face of another body: approaching or not, at the trial
        positions before the correction, over the run and all ranks, in the case's
        length unit (collective)."""
        out = {}
        if self.surface:
            out["surface_contact"] = {"largest_penetration": self.surface.deepest_centre()}
        if self.node_contact:
            out["node_contact"] = {"largest_penetration": self.node_contact.deepest_node()}
        return out

    def energies(self):
        """Kinetic, internal (the elements' hourglass energy included) and total energy
        over all ranks and body kinds; with FEM bodies also ``hourglass`` on its own."""
        if self.exact:                                        # the same bits on any rank count
            parts = exact_totals(self.world, [kind.energy_sums() for kind in self.all_kinds])
        else:
            parts = self.world.sum(np.array([kind.energies() for kind in self.all_kinds],
                                            np.float64))      # one reduction for all
        kinetic = internal = hourglass = 0.0
        for k, i, h in parts:
            kinetic, internal, hourglass = kinetic + k, internal + (i + h), hourglass + h
        e = {"kinetic": kinetic, "internal": internal, "total": kinetic + internal}
        if self.elements:
            e["hourglass"] = hourglass
        return e

    def body_stats(self):
        """Per body the run contract's values, each kind's entry joined to those of the
        kinds before it (an FEM body's from its nodes, with its element and node counts
        and energies, and the particles its elements became)."""
        stats = {}
        for kind in self.all_kinds:
            for name, entry in kind.body_stats(self.world).items():
                stats[name] = merged_stats(entry, stats[name]) if name in stats else entry
        return stats

    def gravitational_potential(self, gravity):
        """-sum m g.x over all ranks and body kinds."""
        if self.exact:
            parts = [acc[0] for acc in exact_totals(
                self.world, [kind.potential_sums(gravity) for kind in self.all_kinds])]
        else:
            parts = self.world.sum(np.array([kind.potential(gravity)
                                             for kind in self.all_kinds]))
        return sum(float(part) for part in parts)

    def load_power(self, vectors):
        """This rank's power of the loads at ``vectors`` (particles and FE nodes)."""
        return sum(kind.load_power(vectors) for kind in self.all_kinds)

    def load_power_terms(self, vectors):
        """The same per loaded point, for exact sums (pmpm.solver.energy.LoadWork)."""
        return np.concatenate([kind.load_power_terms(vectors) for kind in self.all_kinds])

    @property
    def n_elements(self):
        return self.world.sum(sum(kind.element_count() for kind in self.all_kinds))

    def load_vectors(self, time):
        """Load vector of every load at ``time`` (value times its time function)."""
        vec = np.zeros((max(len(self.loads), 1), 3))
        for i, load in enumerate(self.loads):
            vec[i] = np.asarray(load.value, dtype=np.float64) * time_factor(
                load.time_function, time)
        return vec


def initial_histograms(config, grid, x, meshes):
    """The initial cut's histograms along each axis: each particle counts 1, each element
    (by its centroid) its weight (solver.work_weights)."""
    if not meshes:
        return grid.cell_histograms(x)
    weights = body_weights(config, BodyTable(config).rigid)
    centroids = [m.points[m.hexes].mean(axis=1) for m in meshes.values()]
    each = [np.ones(len(x))] + [np.full(len(m.hexes), weights[b]) for b, m in meshes.items()]
    return grid.cell_histograms(np.concatenate([x] + centroids), np.concatenate(each))


def checkpoint_histograms(world, config, grid, bodies, particles, groups):
    """The histograms a restart on another number of ranks cuts its slabs from: this
    rank's particles summed over the ranks, plus the checkpoint's elements (every rank
    reads them all: not summed) by their centroids and weights (solver.work_weights)."""
    counts = [world.sum(h) for h in grid.cell_histograms(particles.x)]
    if not groups or not groups.get("elements"):
        return counts
    elements, nodes = groups["elements"], groups["nodes"]
    order = np.argsort(nodes["node_id"], kind="stable")
    corners = np.searchsorted(nodes["node_id"][order], elements["hexes"])
    centroids = nodes["x"][order][corners].mean(axis=1)
    weights = body_weights(config, bodies.rigid)[elements["body"]]
    return [c + e for c, e in zip(counts, grid.cell_histograms(centroids, weights))]


def build_on_every_rank(world, build):
    """``build()``, or a SetupError on every rank with every rank's problems when it
    fails on any (an initial field may be bad only where some rank has particles)."""
    try:
        result, problems = build(), []
    except SetupError as error:
        result, problems = None, error.problems
    every = [line for lines in world.allgather(problems) for line in lines]
    if every:
        raise SetupError(list(dict.fromkeys(every)))
    return result


def make_windows(grid_config, grid, body_names):
    """The refined windows of the case. A window of ratio 1 is the coarse grid itself: it
    is accepted (so that a case can switch refinement on with a parameter) and left out,
    so that it changes nothing, contact across its faces included."""
    return [Window.from_config(w, grid, body_names) for w in grid_config.windows
            if w.ratio > 1]


def time_factor(function, t):
    """The factor of a ``pmpm.case.TimeFunctionConfig`` at time ``t``."""
    if function.type == "constant":
        return 1.0
    if function.type == "ramp":
        return min(t / function.t_rise, 1.0) if function.t_rise > 0 else 1.0
    if function.type == "table":
        return float(np.interp(t, function.t, function.f))
    raise ValueError(f"unknown time function '{function.type}'")


def merged_stats(elements, particles):
    """One body's summary entry from its elements' and its particles' (those born of
    its elements): masses, counts and moments add, boxes join."""
    if particles["n_particles"] == 0:
        return elements
    mass = elements["mass"] + particles["mass"]
    safe = mass if mass > 0 else 1.0

    def mean(key):
        return ((elements["mass"] * np.asarray(elements[key]) + particles["mass"]
                 * np.asarray(particles[key])) / safe).tolist()
    merged = dict(elements, mass=mass, n_particles=particles["n_particles"],
                  centroid=mean("centroid"), velocity=mean("velocity"),
                  n_failed=elements["n_failed"] + particles["n_failed"])
    merged["bbox_min"] = np.minimum(elements["bbox_min"], particles["bbox_min"]).tolist()
    merged["bbox_max"] = np.maximum(elements["bbox_max"], particles["bbox_max"]).tolist()
    merged["energy"] = {key: value + particles["energy"].get(key, 0.0)
                        for key, value in elements["energy"].items()}
    return merged
