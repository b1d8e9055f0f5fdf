"""Bodies: their materials packed for the kernels, and their initial particles."""
import numpy as np

from ..case.config import converted_into
from ..case.expressions import ExpressionError, evaluate_field
from ..materials import catalog, layout
from ..particles import particle_store
from ..particles.store import IDENTITY9, empty_column
from .errors import SetupError


class BodyTable:
    """Per-body arrays the kernels index by ``particles.body``, from a CaseConfig."""

    def __init__(self, config):
        bodies = config.bodies
        self.names = [b.name for b in bodies]
        self.codes = np.zeros(len(bodies), np.int64)
        self.params = np.zeros((len(bodies), layout.N_SLOTS))
        for i, body in enumerate(bodies):
            self.codes[i], self.params[i] = catalog.pack(config.materials[body.material])
        self.rigid = (self.codes == layout.RIGID)
        #: rigid bodies that impose their velocity on the grid (a free rigid FEM body,
        #: ``rigid.free``, meets the others there with its nodes' masses instead; a free
        #: rigid particle body imposes its velocity too, and then takes the contact's
        #: impulses, pmpm.solver.rigid_particles)
        self.grid_rigid = self.rigid & ~np.array(
            [bool(b.free_axes) and b.is_fem for b in bodies], bool)
        #: per body the spacing, in cells, of the particles born of an FEM body's
        #: elements (``BodyConfig.born_spacing``; a body added for them, ``born_of``: its
        #: FEM body's), 0 where none are
        spacing = {b.name: b.born_spacing for b in bodies if b.born_spacing}
        self.born_spacing = np.array([spacing.get(b.born_of or b.name, 0.0)
                                      / config.grid.cell for b in bodies])
        #: per body the index of the particle body that takes its converted elements'
        #: particles (pmpm.case.config.converted_bodies), or -1: they stay in the body
        self.converted_into = converted_into(bodies)
        #: the FEM bodies whose converted particles stay in them and meet what is left
        #: of their own mesh by surface contact (IAFEMP)
        self.meets_own_mesh = (self.born_spacing > 0) & (self.converted_into < 0) & \
            np.array([b.is_fem for b in bodies], bool)
        #: the particles' uGIMP half-width in cells: half the lattice spacing (an FEM
        #: body's: half that of the particles born of its elements)
        self.half_width = np.array([0.5 * spacing if spacing else 0.5 / b.particles_per_cell
                                    for spacing, b in zip(self.born_spacing, bodies)])

    def initial_wave_speed(self, body_index):
        """sqrt((K + 4G/3)/rho0), or the EOS sound speed where larger (or the only one)."""
        prm = self.params[body_index]
        speed = 0.0
        if prm[layout.K] > 0 and np.isfinite(prm[layout.K]):
            speed = np.sqrt((prm[layout.K] + 4 * prm[layout.G] / 3) / prm[layout.RHO0])
        return max(speed, prm[layout.EOS_C0])


def fill_positions(config, fill_body, case_dir):
    """Positions and volumes of every body's particles (the same on every rank), as a
    list of (positions, volumes) per body. Only these few bytes per particle are held for
    all particles; the full columns are built for a rank's own particles only. An FEM
    body has no particles (its mesh: solver.fem_bodies.build_meshes)."""
    case = config.case
    listed = [fill_body(body, case["grid"], case_dir) if body.get("method") != "fem"
              else (np.zeros((0, 3)), np.zeros(0)) for body in case["bodies"]]
    added = len(config.bodies) - len(listed)        # the bodies of converted elements
    return listed + [(np.zeros((0, 3)), np.zeros(0))] * added


def build_particles(config, table, filled, keep):
    """The particles of every body selected by ``keep`` (bool mask over the concatenated
    fill); global ids are the fill order, so they agree on every rank count."""
    store = particle_store(config.time.transfer == "apic")
    parts, offset = [], 0
    for index, (positions, volumes) in enumerate(filled):
        mine = keep[offset:offset + len(volumes)]
        cols = _body_columns(index, config.bodies[index], table, positions[mine],
                             volumes[mine], config.grid.cell, store.COLUMNS)
        cols["id"][:] = offset + np.flatnonzero(mine)
        parts.append(cols)
        offset += len(volumes)
    columns = {}
    for name in store.COLUMNS:   # column by column, freeing each body's part as we go
        columns[name] = np.concatenate([part.pop(name) for part in parts])
    return store(columns)


def _body_columns(index, body, table, positions, volumes, cell, names):
    n = len(volumes)
    cols = {name: empty_column(name, n) for name in names}
    prm = table.params[index]
    cols["x"][:] = positions
    cols["x0"][:] = positions
    for d, component in enumerate(body.velocity):
        cols["v"][:, d] = initial_field(component, positions, f"bodies[{index}].velocity[{d}]")
    cols["vol0"][:] = volumes
    cols["rho"][:] = prm[layout.RHO0]
    cols["mass"][:] = prm[layout.RHO0] * volumes
    cols["F"][:] = IDENTITY9
    temperature = prm[layout.T_ROOM] if body.temperature is None else body.temperature
    cols["temp"][:] = initial_field(temperature, positions, f"bodies[{index}].temperature")
    cols["body"][:] = index
    cols["load"][:] = -1
    cols["refine"][:] = refinement(volumes, cell / body.particles_per_cell)
    return cols


def initial_field(value, positions, key):
    """A number, or a field expression of x, y, z (``pmpm.case.expressions``) at the
    particles' ``positions``; a value that is not finite is a SetupError naming ``key``."""
    if not isinstance(value, str):
        return value
    try:
        return evaluate_field(value, positions)
    except ExpressionError as error:
        raise SetupError([f"{key}: {error}"]) from None


def refinement(volumes, spacing):
    """How many times finer than the coarse lattice ``spacing`` each particle was filled
    (1 outside windows, R inside a window of ratio R: its volume is (spacing / R)^3)."""
    return np.maximum(np.rint(np.cbrt(spacing ** 3 / volumes)), 1).astype(np.int32)


def assign_loads(config, particles, count_global):
    """Mark the particles each load acts on; returns problems (key paths) for loads that
    select nothing. ``count_global`` sums a count over ranks."""
    problems = []
    names = [b.name for b in config.bodies]
    for i, load in enumerate(config.loads):
        if config.bodies[names.index(load.body)].is_fem:
            continue                    # its nodes: solver.fem_bodies.FemBodies
        selected = _in_region(particles, names.index(load.body), load.region)
        n_global = count_global(int(selected.sum()))
        if n_global == 0:
            problems.append(f"loads[{i}].region: selects no particle of body '{load.body}'")
            continue
        particles.load[selected] = i
        if load.type == "traction":
            particles.load_scale[selected] = particles.vol0[selected] ** (2.0 / 3.0)
        else:
            particles.load_scale[selected] = 1.0 / n_global
    return problems


def _in_region(particles, body_index, region):
    lo, hi = np.asarray(region.min), np.asarray(region.max)
    inside = np.all((particles.x >= lo) & (particles.x <= hi), axis=1)
    return inside & (particles.body == body_index)
