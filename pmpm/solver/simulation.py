"""Build the initial state of a run from a validated case, or from a checkpoint."""
import numpy as np

from ..comm.slabs import Slabs, choose_slabs
from ..grid import CoarseGrid, Window
from ..particles import Particles
from .bodies import BodyTable, assign_loads, build_particles, fill_positions
from .errors import SetupError
from .step import Stepper


class Simulation:
    """Everything one rank needs to step a case: grid, slabs, its particles, bodies."""

    def __init__(self, world, case, grid, slabs, particles, bodies, id_base=None):
        self.world, self.case, self.grid = world, case, grid
        self.bodies = bodies
        n_total = max(world.sum(particles.n), 1)
        mean_mass = world.sum(float(particles.mass.sum())) / n_total
        self.windows = make_windows(case, grid, bodies.names)
        self.stepper = Stepper(world, grid, slabs, particles, bodies,
                               case.get("gravity", [0, 0, 0]), 1e-12 * mean_mass,
                               case.get("contact"), self.windows,
                               n_total if id_base is None else id_base,
                               case.get("time", {}).get("scheme", "usf"))
        self.loads = case.get("loads", [])
        self.time, self.step_count = 0.0, 0

    @property
    def particles(self):
        return self.stepper.particles

    @property
    def slabs(self):
        return self.stepper.slabs

    @classmethod
    def from_case(cls, world, case, case_dir, fill_body):
        grid = CoarseGrid.from_case(case["grid"])
        bodies = BodyTable(case)
        filled = fill_positions(case, fill_body, case_dir)
        x = np.concatenate([positions for positions, _ in filled])
        slabs = decompose(world, grid, x, case)
        mine = slabs.owner_of_cells(grid.cells_of(x)[:, slabs.axis]) == world.rank
        del x
        particles = build_particles(case, bodies, filled, mine)
        problems = assign_loads(case, particles, world.sum)
        if problems:
            raise SetupError(problems)
        return cls(world, case, grid, slabs, particles, bodies)

    @classmethod
    def from_checkpoint(cls, world, case, scalars, columns):
        grid = CoarseGrid.from_case(case["grid"])
        bodies = BodyTable(case)
        particles = Particles(columns)
        slabs = Slabs(scalars["slab_axis"], scalars["slab_bounds"])
        if len(slabs.bounds) != world.size + 1:
            counts = [world.sum(h) for h in grid.cell_histograms(particles.x)]
            slabs = choose_slabs(counts, world.size, "xyz"[scalars["slab_axis"]])
        refined = scalars.get("refine")
        sim = cls(world, case, grid, slabs, particles, bodies,
                  refined["id_base"] if refined else None)
        if refined:
            sim.stepper.refiner.restore(refined)
        sim.stepper.send_to_owners(slabs)
        sim.stepper.cell_ranges = sim.stepper.global_cell_ranges()
        sim.time, sim.step_count = scalars["time"], scalars["step"]
        return sim

    def initial_speed(self):
        """Largest initial wave speed plus particle speed, over all ranks."""
        p = self.particles
        c = np.array([self.bodies.initial_wave_speed(b) for b in range(len(self.bodies.names))])
        speeds = c[p.body] + np.linalg.norm(p.v, axis=1) if p.n else np.zeros(1)
        finest = max([w.ratio for w in self.windows] + [1])
        return self.world.max(float(speeds.max())) * finest

    def load_vectors(self, time):
        """Load vector of every load at ``time`` (value times its time function)."""
        vec = np.zeros((max(len(self.loads), 1), 3))
        for i, load in enumerate(self.loads):
            vec[i] = np.asarray(load["value"], dtype=np.float64) * time_factor(
                load.get("time_function", {"type": "constant"}), time)
        return vec


def make_windows(case, grid, body_names):
    """The refined windows of the case. A window of ratio 1 is the coarse grid itself: it
    is accepted (so that a case can switch refinement on with a parameter) and left out,
    so that it changes nothing, contact across its faces included."""
    return [Window.from_case(w, grid, body_names) for w in case["grid"].get("windows", [])
            if w["ratio"] > 1]


def decompose(world, grid, x, case):
    """Slabs chosen from the full particle set (every rank holds the same fill)."""
    settings = case.get("decomposition", {})
    return choose_slabs(grid.cell_histograms(x), world.size, settings.get("axis", "auto"))


def time_factor(function, t):
    kind = function.get("type", "constant")
    if kind == "constant":
        return 1.0
    if kind == "ramp":
        return min(t / function["t_rise"], 1.0) if function["t_rise"] > 0 else 1.0
    if kind == "table":
        return float(np.interp(t, function["t"], function["f"]))
    raise ValueError(f"unknown time function '{kind}'")
