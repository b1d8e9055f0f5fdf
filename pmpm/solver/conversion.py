"""Elements that turn into particles (IAFEMP, seed 004 Secs. 3-4;
``shared/seeds/004_NOTES.md`` Sec. 1.4).

At the end of a step, after the points and the FE nodes have moved, an element of a body
with ``fem.convert`` becomes n^3 particles of the same body when its plastic strain
reaches ``convert.eps_p``, when its volume falls to ``convert.volume_ratio`` of its
initial volume, when its stable step (as the last force pass took it: its shape, its
current wave speed and viscosities) falls to ``convert.step_ratio`` of the background
cell's step (:func:`cell_rates`: the step at rest of an undistorted cube of the body's
material and element one coarse cell wide), when its material has failed (damage 1;
``convert.failed``, on unless set false), or whenever it would invert (volume at most
0):

* the particles sit at the centres of the element's n^3 sub-cells in its natural
  coordinates, xi = (2a + 1)/n - 1, mapped by the element's trilinear shape functions
  N_K; each takes m_e / n^3 of the element's mass and vol0_e / n^3 of its initial volume,
  the velocity sum_K N_K(xi_p) v_K of its nodes, and the element's whole material state
  (stress, F, density, plastic strain, specific internal energy, temperature, bulk
  viscosity);
* each node K of the element gives up m_e / 8 of its lumped mass, its velocity unchanged.
  At the symmetric sub-cell centres sum_p N_K(xi_p) = n^3 / 8, so the particles carry
  exactly the momentum the nodes lose (to round-off), and all of the element's mass;
* ids are ``id_base + n_max^3 * element id + k``, the same on any rank count; ``id_base``
  is the count of the run's initial particles, and the refined windows' splitting counts
  ids from above every id conversion can give (pmpm.solver.simulation);
* in the same step the step's transfer hook (pmpm.solver.transfer.ElementsToParticles)
  takes the converted elements off with the FEM kind's general removal
  (``FemBodies.remove_elements``: every rank drops their share of the masses of the
  nodes it holds, the converted elements of all ranks gathered only when some element
  converts and applied in element id order so that every copy of a shared node, and 1
  rank against N, agree; the nodes no element of its own uses any more go), and the
  kind's ``elements_changed`` event has the couplings rebuild what depends on the mesh
  (the free faces of surface contact, so that the dead element's neighbours' exposed
  faces are segments before the next step's contact). The particles' spacing
  (``BodyConfig.born_spacing``) sizes their shape functions and has surface contact let
  them meet the rest of their own mesh.

It is built from the registry (pmpm.solver.registry, ``bodies[i].fem.convert``:
:func:`build_conversion`); the particle ids it reserves (``reserved_ids``) are kept out
of the refined windows' splitting by the simulation.

Why the cell's step is the reference of ``step_ratio``: the run's step is the shortest of the
grid's (a wave crossing one coarse cell, the particles' CFL step) and the elements'. An
element whose step falls far below the cell's makes every other part of the run pay for
it; as particles its material runs at the grid's step. The reference is the same for
every mesh of a body, so the criterion's floor, and the shortest step a run may keep,
do not depend on how small the mesh's smallest element is (the ogive rod's flat tip,
before its mesh got a cap, was 0.2 of its head element: a reference taken from the mesh
made the 2.3 mm rod's floor five times lower than the 5.7 mm rod's;
docs/validation/ogive_plate_fem.md). It is computed from the case alone, so it needs no
reduction over the ranks and no checkpoint entry. An element already below the floor at
the start (finer than the grid resolves: the 2.3 mm rod's 20 flat-tip elements at 2 mm
cells, before its mesh had a cap) converts after the first force pass.

The converted element's hourglass energy stays in the energy balance (FemBodies keeps
it, ``removed_hourglass``); the kinetic energy the nodes lose beyond what the particles
take (the velocity field's variation over the element) is counted in ``kinetic_loss``.
"""
import sys

import numpy as np

from ..case.config import converted_into

from ..case.fem import MAX_CONVERT_DIVISIONS
from ..fem.criteria import elements_to_convert
from ..particles.store import COLUMNS, empty_column
from .bodies import refinement
from .fem_bodies import rates_at_rest
from .transfer import ElementsToParticles, Transfer

#: natural coordinates of the 8 nodes (VTK order, pmpm.fem.hexahedron)
CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                    [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], np.float64)
#: ids kept for each element's particles: enough for the most a case may ask
ID_STRIDE = MAX_CONVERT_DIVISIONS ** 3
#: how far apart two computations of one volume ratio may be (see Conversion.chosen)
ROUND_OFF = 1e-12


class ConversionRules:
    """Per body the conversion criteria: ``divisions`` (nb,) int (0: the body does not
    convert), ``eps_p``, ``volume_ratio`` and ``step_ratio`` (nb,) (inf / 0 / 0 where not
    set); ``into`` (nb,) the body its elements' particles join: itself, or the particle
    body added for them where it meets bodies on the grid
    (pmpm.case.config.converted_bodies)."""

    def __init__(self, config):
        nb = len(config.bodies)
        added = converted_into(config.bodies)
        self.into = np.where(added >= 0, added, np.arange(nb))
        self.divisions = np.zeros(nb, np.int64)
        self.eps_p = np.full(nb, np.inf)
        self.volume_ratio = np.zeros(nb)
        self.step_ratio = np.zeros(nb)
        self.failed = np.zeros(nb)           # 1: a failed element (damage 1) converts
        #: time.dt where the step is fixed, else None: an element whose stable step
        #: falls below it converts too (Conversion.floor_rates)
        self.fixed_dt = config.time.dt
        for b, body in enumerate(config.bodies):
            convert = body.convert
            if convert is None:
                continue
            self.divisions[b] = convert.particles_per_direction
            self.eps_p[b] = np.inf if convert.eps_p is None else convert.eps_p
            self.volume_ratio[b] = convert.volume_ratio or 0.0
            self.step_ratio[b] = convert.step_ratio or 0.0
            self.failed[b] = float(convert.failed)

    @property
    def active(self):
        return bool(self.divisions.any())


def floor_rates(rules, cell_rates, fixed=True):
    """(nb,) per body the stable rate (1 / step at cfl 1) at which an element converts,
    0 where none: the cell's rate over ``step_ratio``, and with a fixed step (``fixed``
    and time.dt set) at most 1 / time.dt, the rate of an element that the fixed step
    would take past its stability (the paper's Table 6 runs fixed steps of 1-4e-5 ms; at
    1 mm pmpm stopped them when a crushed plate element's step fell below 2e-5 ms)."""
    with np.errstate(divide="ignore"):
        floors = np.where((rules.step_ratio > 0) & (cell_rates > 0),
                          cell_rates / np.maximum(rules.step_ratio, 1e-300), np.inf)
    if fixed and rules.fixed_dt is not None:
        floors = np.minimum(floors, 1.0 / rules.fixed_dt)
    return np.where(np.isfinite(floors) & (rules.divisions > 0), floors, 0.0)


def build_conversion(setup):
    """The registry's builder (pmpm.solver.registry.Setup): the conversion of the bodies
    with ``fem.convert``, or None when no body converts."""
    rules = ConversionRules(setup.config)
    if setup.elements is None or not rules.active:
        return None
    mover = ElementsToParticles(setup.world, setup.elements, setup.points)
    return Conversion(setup.world, rules, mover, setup.n_total, setup.grid.h,
                      [b.particles_per_cell for b in setup.config.bodies])


class Conversion(Transfer):
    """Turns this rank's failing elements into particles at the end of each step
    (collective: one OR reduction per step; a gather and the couplings' rebuild only in
    a step where some element converts).

    Parameters
    ----------
    world : comm.World
    rules : ConversionRules
    mover : solver.transfer.ElementsToParticles   the step's hook that moves the
        elements' material into the particles (its ``elements``: the FEM bodies)
    id_base : int   the number of the run's initial particles
    cell, particles_per_cell : the coarse cell and each body's lattice (the particles'
        ``refine`` column, as a filled body's)
    """

    def __init__(self, world, rules, mover, id_base, cell, particles_per_cell):
        self.world, self.rules, self.mover = world, rules, mover
        self.elements = mover.elements
        self.id_base, self.cell = int(id_base), float(cell)
        self.particles_per_cell = np.asarray(particles_per_cell, np.float64)
        self.converted = 0           # elements, over all ranks, since the start
        self.kinetic_loss = 0.0      # this rank's share
        self.cell_rates = cell_rates(self.elements, self.cell) \
            if self.rules.step_ratio.any() else np.zeros(len(self.rules.step_ratio))
        self.floor_rates = floor_rates(self.rules, self.cell_rates)
        self.warn_of_fine_elements()

    def warn_of_fine_elements(self):
        """Print (rank 0) how many elements of each body start with a step already at
        most ``step_ratio`` of the cell's: finer than the grid, they convert after the
        first step (collective when some body converts on the step)."""
        if not self.rules.step_ratio.any():
            return
        fem = self.elements
        fine = np.zeros(len(self.cell_rates))
        if fem.n_elements:
            at_start = self.at_the_floor(fem.body, fem.shape_rates(initial=True))
            np.add.at(fine, fem.body, at_start.astype(np.float64))
        fine = self.world.sum(fine)
        for b in np.flatnonzero(fine > 0):
            if self.world.is_root:
                sys.stderr.write(
                    f"pmpm: warning: body '{fem.names[b]}': {int(fine[b])} elements start "
                    f"with a stable step at most fem.convert.step_ratio "
                    f"({self.rules.step_ratio[b]:g}) of the cell's step "
                    f"({1 / self.cell_rates[b]:.3g} at grid.cell {self.cell:g}); finer "
                    f"than the grid, they convert after the first step\n")
                sys.stderr.flush()

    @property
    def reserved_ids(self):
        """The ids its particles may take above ``id_base``: a stride per element."""
        return ID_STRIDE * self.elements.n_elements_total

    def state(self):
        """What a checkpoint keeps (collective): the ids, the count, and the energies
        the converted elements leave behind, summed over the ranks."""
        hourglass, loss = self.world.sum(np.array([self.elements.removed_hourglass,
                                                   self.kinetic_loss]))
        return {"id_base": self.id_base, "converted": self.converted,
                "hourglass": float(hourglass), "kinetic_loss": float(loss)}

    def restore(self, state):
        """Take a checkpoint's :meth:`state` (its energies on rank 0). The step
        criterion's reference comes from the case (:func:`cell_rates`); the body's
        shortest first step that earlier checkpoints kept (``start_rates``) is not read."""
        self.id_base, self.converted = int(state["id_base"]), int(state["converted"])
        if self.world.is_root:
            self.elements.removed_hourglass = float(state["hourglass"])
            self.kinetic_loss = float(state["kinetic_loss"])

    def transfer(self):
        """Convert the elements that meet their body's criteria (collective). With a
        fixed step the FEM kind's speed is then that of the elements left: a converted
        element's stable step, below time.dt, would stop the run at the next step's check
        (pmpm.solver.run) although the element is gone. Under time.cfl the next step
        follows the force pass's speed, converted elements included, as before."""
        chosen = self.chosen()
        if not self.world.any(bool(chosen.any())):
            return 0
        fem, fixed = self.elements, self.rules.fixed_dt is not None
        left = fem.step_rates()[~chosen].max(initial=0.0) if fixed else None
        count, loss = self.mover.move(chosen, self.particles_of(np.flatnonzero(chosen)))
        if fixed:
            fem.speed = left * fem.h
        self.kinetic_loss += loss
        self.converted += count
        return count

    def chosen(self):
        """Which of this rank's elements convert now (pmpm.fem.criteria). The current
        volumes come from the faces, the reference ones from the mean gradient at set-up
        (the element masses carry their bits): the same to round-off, so a ratio within
        ROUND_OFF of its bound is at it (an element at rest converts at 1)."""
        fem = self.elements
        if not fem.n_elements:
            return np.zeros(0, bool)
        return self.choose(fem.body, fem.state.eps_p, fem.state.damage, fem.volumes(),
                           fem.vol0, fem.step_rates(), ROUND_OFF)

    def choose(self, b, eps_p, damage, volumes, vol0, rates, round_off, floors=None):
        """The criteria on elements of bodies ``b`` (pmpm.fem.criteria); ``floors``:
        per body the stable rate at which an element converts (default
        :attr:`floor_rates`; 0: none)."""
        r = self.rules
        floors = self.floor_rates if floors is None else floors
        out = np.empty(len(b), np.bool_)
        elements_to_convert(np.ascontiguousarray(b), eps_p, damage, volumes, vol0, rates,
                            r.divisions, r.eps_p, r.failed, r.volume_ratio, round_off,
                            (floors > 0).astype(np.float64), floors, out)
        return out

    def at_the_floor(self, b, rates):
        """Which elements, of bodies ``b`` with stable ``rates`` (1 / step), have a step
        at most ``step_ratio`` of their body's cell step: their rate at least the cell's
        rate over the ratio; none of a body that does not convert on the step or has no
        wave speed (a rigid one). The step criterion alone, for the warning at the start
        (at rest): the other criteria cannot hold (a plastic strain of minus infinity, a
        volume ratio of 1 against a bound of minus infinity, no damage)."""
        ones = np.ones(len(b))
        cell_floor = floor_rates(self.rules, self.cell_rates, fixed=False)
        return self.choose(b, np.full(len(b), -np.inf), np.zeros(len(b)), ones, ones,
                           np.ascontiguousarray(rates, np.float64), -np.inf, cell_floor)

    def particles_of(self, converted):
        """The particle columns of the elements ``converted`` (local indices)."""
        fem = self.elements
        parts = [{name: empty_column(name, 0) for name in COLUMNS}]   # none here
        for n in np.unique(self.rules.divisions[fem.body[converted]]):
            group = converted[self.rules.divisions[fem.body[converted]] == n]
            parts.append(self.particles_of_group(group, int(n)))
        return {name: np.concatenate([part[name] for part in parts]) for name in COLUMNS}

    def particles_of_group(self, group, n):
        fem = self.elements
        k = n ** 3
        shape = sub_cell_shapes(n)                                   # (k, 8)
        x, v = fem.x[fem.hexes[group]], fem.v[fem.hexes[group]]     # (m, 8, 3)
        columns = {name: empty_column(name, len(group) * k) for name in COLUMNS}
        columns["x"][:] = np.einsum("kn,mnd->mkd", shape, x).reshape(-1, 3)
        columns["x0"][:] = np.einsum("kn,mnd->mkd", shape,
                                     fem.x0[fem.hexes[group]]).reshape(-1, 3)
        columns["v"][:] = np.einsum("kn,mnd->mkd", shape, v).reshape(-1, 3)
        columns["mass"][:] = np.repeat(fem.element_mass[group] / k, k)
        columns["vol0"][:] = np.repeat(fem.vol0[group] / k, k)
        for name, column in fem.state._asdict().items():
            columns[name][:] = np.repeat(column[group], k, axis=0)
        body = fem.body[group]
        columns["body"][:] = np.repeat(self.rules.into[body], k)
        columns["load"][:] = -1
        columns["id"][:] = (self.id_base + ID_STRIDE * fem.element_id[group][:, None]
                            + np.arange(k)[None, :]).ravel()
        spacing = self.cell / self.particles_per_cell[columns["body"]]
        columns["refine"][:] = refinement(columns["vol0"], spacing)
        return columns


def cell_rates(fem, cell):
    """(nb,) per body the stable rate (1 / step at cfl 1) at rest of an undistorted cube
    of edge ``cell`` with the body's material (initial density and wave speed) and
    element formulation (its hourglass form and coefficient): the step criterion's
    reference, the step an element as wide as the background cell would have
    (pmpm.fem.stability; about 1.8 c / cell with the viscous hourglass form at 0.1).
    0 for a body without a wave speed. The same on every rank and for every mesh."""
    nb = len(fem.hourglass.kind)
    cube = CORNERS * (0.5 * float(cell))
    x = np.ascontiguousarray(np.tile(cube, (nb, 1)))
    hexes = np.arange(8 * nb, dtype=np.int64).reshape(nb, 8)
    return rates_at_rest(fem.table, x, hexes, np.arange(nb), fem.hourglass.kind,
                         fem.hourglass.coefficient)


def sub_cell_shapes(n):
    """(n^3, 8) the trilinear shape functions at the centres of the n^3 sub-cells of the
    natural cube [-1, 1]^3."""
    centres = (2.0 * np.arange(n) + 1.0) / n - 1.0
    a, b, c = np.meshgrid(centres, centres, centres, indexing="ij")
    xi = np.stack([a.ravel(), b.ravel(), c.ravel()], axis=1)
    return np.prod(1.0 + xi[:, None, :] * CORNERS[None, :, :], axis=2) / 8.0
