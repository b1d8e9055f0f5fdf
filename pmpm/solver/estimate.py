"""The size of a run, estimated before the kernels compile: particles, time steps (end
time over the first time step) and bytes of output, with the limits that refuse a run
that cannot finish (``time.max_steps``) or whose output cannot fit on the disk."""
import math
import shutil
from dataclasses import dataclass

import numpy as np

from ..case.contact import describe_contact
from ..io.history import BODY_FIELDS
from ..particles import COLUMNS, particle_store
from .bodies import BodyTable, initial_field
from .errors import SetupError

#: Columns of a particle frame (run.Runner.write_frame), as named in the store.
FRAME_COLUMNS = ("x", "v", "stress", "eps_p", "rho", "mass", "body", "id", "temp", "e_int",
                 "damage")
#: Bytes of the derived columns of a particle or element frame (pressure, von Mises).
DERIVED_BYTES = 16
#: Checkpoints on disk at once: the two kept and the one being written.
CHECKPOINTS_AT_ONCE = 3
#: Relative round-off allowed between a fixed step and the stable step it may equal.
STEP_SLACK = 1e-9
#: Bytes of one number in history.csv (a repr-formatted float and its comma).
HISTORY_NUMBER_BYTES = 24
#: Bytes of an element and of a node in a frame of elements.h5 (pmpm.io.elements_h5:
#: id, stress, eps_p, density, e_int, damage, centroid, hourglass energy; id, x, v) and
#: in a checkpoint (the same with the connectivity, the reference positions and the
#: state, plastic work included).
ELEMENT_FRAME_BYTES, NODE_FRAME_BYTES = 120 + DERIVED_BYTES, 56
ELEMENT_CHECKPOINT_BYTES, NODE_CHECKPOINT_BYTES = 216, 100


def bytes_per_particle(names):
    """Bytes one particle takes in the columns ``names``."""
    return sum(np.dtype(COLUMNS[n][0]).itemsize * COLUMNS[n][1] for n in names)


@dataclass(frozen=True)
class RunSize:
    particles: int
    first_dt: float
    steps: float
    frames: int
    output_bytes: float
    stable_dt: float = math.inf      # at cfl 1, from the same speed
    cfl: float | None = None         # the Courant number taken; None: a fixed step

    def line(self, free_bytes):
        """The line rank 0 prints before the run."""
        free = "" if free_bytes is None else f" ({_size(free_bytes)} free)"
        step = "fixed" if self.cfl is None else f"cfl {self.cfl:g}: first"
        return (f"pmpm: {self.particles:,} particles; about {_count(self.steps)} steps "
                f"({step} time step {self.first_dt:.3g}); output about "
                f"{_size(self.output_bytes)} in {_frames(self.frames)}{free}")


def _frames(n):
    return f"{n} frame" + ("" if n == 1 else "s")


def _count(x):
    return f"{x:,.0f}" if x < 1e7 else f"{x:.2g}"


def _size(n):
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def initial_speed(config, filled, meshes=None):
    """Fastest initial wave plus particle speed over the bodies, times the finest
    window's ratio: the coarse-grid speed of the same Courant number (as
    Simulation.initial_speed, but from the filled positions, before any particle is
    built); and of the FEM bodies' ``meshes``, cell / their elements' stable step."""
    table = BodyTable(config)
    elements = max([element_speed(config, table, b, mesh) * config.grid.cell
                    for b, mesh in (meshes or {}).items()] + [0.0])
    fastest = 0.0
    for b, (positions, _) in enumerate(filled):
        if len(positions) == 0:
            continue
        v = np.zeros((len(positions), 3))
        for d, component in enumerate(config.bodies[b].velocity):
            v[:, d] = initial_field(component, positions, f"bodies[{b}].velocity[{d}]")
        fastest = max(fastest, table.initial_wave_speed(b) + float(
            np.sqrt((v * v).sum(axis=1)).max()))
    return max(fastest * max([w.ratio for w in config.grid.windows] + [1]), elements)


def element_speed(config, table, b, mesh):
    """1 / the stable step at cfl 1 of the elements of FEM body ``b``'s ``mesh`` at the
    start (pmpm.fem.stability, hourglass included)."""
    from .fem_bodies import hourglass_form, start_rate
    if len(mesh.hexes) == 0:
        return 0.0
    nb = len(config.bodies)
    kind, coefficient = np.zeros(nb, np.int64), np.zeros(nb)
    kind[b], coefficient[b] = hourglass_form(config.bodies[b].fem)
    body = np.full(len(mesh.hexes), b, np.int32)
    return start_rate(table, np.asarray(mesh.points, np.float64), mesh.hexes, body, kind,
                      coefficient)


def estimate(config, n_particles, fastest, t0=0.0, first_frame=True, elements=(0, 0)):
    """RunSize of the run of ``config`` from time ``t0`` with ``n_particles`` (and
    ``elements``: the FEM bodies' element and node counts) and the coarse-grid
    equivalent wave plus particle speed ``fastest`` (as the run loop's)."""
    from .run import Schedule
    time, output = config.time, config.output
    dt = time.cfl * config.grid.cell / fastest if fastest > 0 else math.inf
    dt = min(dt, time.dt_max or math.inf)
    stable = config.grid.cell / fastest if fastest > 0 else math.inf
    if time.dt is not None:
        dt = time.dt
    remaining = max(float(time.end) - t0, 0.0)
    frame_times = [t for t in Schedule(output, float(time.end)).times
                   if t > t0 + 1e-12 * time.end]
    frames = len(frame_times) + (1 if first_frame else 0)
    steps = remaining / dt if math.isfinite(dt) else 1.0
    steps = math.ceil(steps) + len(frame_times) if steps < 1e15 else steps
    rows = steps / output.history_every + frames
    row_bytes = HISTORY_NUMBER_BYTES * (6 + len(BODY_FIELDS) * len(config.bodies))
    n_elements, n_nodes = elements
    kept = CHECKPOINTS_AT_ONCE if output.checkpoints else 0
    out = (frames * (n_particles * (bytes_per_particle(FRAME_COLUMNS) + DERIVED_BYTES)
                     + n_elements * ELEMENT_FRAME_BYTES + n_nodes * NODE_FRAME_BYTES)
           + kept * (n_particles * bytes_per_particle(
               particle_store(config.time.transfer == "apic").COLUMNS)
                     + n_elements * ELEMENT_CHECKPOINT_BYTES + n_nodes * NODE_CHECKPOINT_BYTES)
           + rows * row_bytes)
    return RunSize(int(n_particles), dt, float(steps), frames, float(out), stable,
                   None if time.dt is not None else float(time.cfl))


def size_problems(config, size, free_bytes):
    """Lines naming the key of each limit the run exceeds."""
    problems = fixed_step_problems(config, size)
    limit = config.time.max_steps
    if size.steps > limit:
        problems.append(
            f"time.end: {config.time.end:g} takes about {_count(size.steps)} time steps of "
            f"the first one ({size.first_dt:.3g}), more than time.max_steps = {limit:g}; "
            f"check the case's speeds and end time, or raise time.max_steps")
    if not problems and free_bytes is not None and size.output_bytes > free_bytes:
        problems.append(
            f"output.frames: the run would write about {_size(size.output_bytes)} "
            f"({_frames(size.frames)} of {size.particles:,} particles, checkpoints, history) "
            f"but the output directory has {_size(free_bytes)} free; write fewer frames "
            f"(output.frames, output.every, output.times), no checkpoints "
            f"(output.checkpoints: false) or choose another --out")
    return problems


def fixed_step_problems(config, size):
    """The line naming time.dt when the fixed step exceeds the stable step at the start
    (cfl 1: the cell over the fastest wave plus body speed, windows' ratios and the FEM
    elements' own steps included)."""
    fixed = config.time.dt
    if fixed is None or not fixed > size.stable_dt * (1 + STEP_SLACK):
        return []
    return [f"time.dt: {fixed:g} exceeds the stable step at the start, "
            f"{size.stable_dt:.4g} (at cfl 1, from the fastest wave plus body speed over "
            f"the grid's cells of {config.grid.cell:g} and the FEM elements' own steps); "
            f"take at most that, or leave time.dt out to follow time.cfl"]


def free_bytes(directory):
    """Free bytes on the file system of ``directory``, or None where unknown."""
    try:
        return shutil.disk_usage(directory).free
    except OSError:
        return None


def check_size(world, config, n_particles, fastest, out, t0=0.0, first_frame=True,
               elements=(0, 0)):
    """Estimate the run and raise SetupError naming the keys of the limits it exceeds
    (collective: rank 0 decides; ``fastest`` is a function giving the coarse-grid speed).
    ``fastest`` runs on every rank: with FEM bodies it loads the elements' stability
    kernel, and with it Numba's target context (about 0.2 s), which every rank needs
    before its warm-up anyway; called on rank 0 alone, the others waited for it here and
    rank 0 then waited for theirs (0.24 s more on 2 ranks). Returns the line to print
    before the run (on rank 0; None on the others)."""
    result = None
    try:
        speed, failure = fastest(), None
    except SetupError as error:
        speed, failure = None, error
    if world.is_root:
        try:
            if failure is not None:
                raise failure
            size = estimate(config, n_particles, speed, t0, first_frame, elements)
        except SetupError as error:
            result = (error.problems, None)
        else:
            free = free_bytes(out)
            rule = describe_contact(config.contact)
            result = (size_problems(config, size, free),
                      size.line(free) + (f"; {rule}" if rule else ""))
    problems, line = world.bcast(result)
    if problems:
        raise SetupError(problems)
    return line if world.is_root else None
