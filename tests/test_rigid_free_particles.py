"""Free rigid particle bodies (``rigid.free`` on a particle body, pmpm.solver.
rigid_particles): a rigid particle block free in z dropped on an elastic particle block
by grid contact (tests/cases/rigid_particle_drop.yaml) and on an elastic FEM plate by
grid coupling (tests/cases/rigid_particle_on_fem_plate.yaml). Nothing touches the grid's
faces, so the z momentum of the two bodies grows by exactly (total mass) g t through the
contact, while the block's held x and y velocities stay zero although friction pushes
it along x. A restart continues the run bitwise; on 2 ranks (pytest-mpi) the answer is
the 1-rank answer to round-off.
Run the MPI part with:
mpirun -n 2 python -m pytest --with-mpi -m mpi tests/test_rigid_free_particles.py"""
import os

import numpy as np
import pytest

from pmpm.case.errors import CaseError
from pmpm.case.loader import load_case

HERE = os.path.dirname(os.path.abspath(__file__))
ON_BLOCK = os.path.join(HERE, "cases", "rigid_particle_drop.yaml")
ON_PLATE = os.path.join(HERE, "cases", "rigid_particle_on_fem_plate.yaml")
END = 0.018                 # 97 steps; the blow from 0.010 s
PLATE_END = 0.02            # 157 steps; the blow from 0.016 s (the grid contact pushes
#                             across the last 1.25 cells of the gap from 0.005 s)
G = 10.0
WEIGHT = 1                  # the free rigid body's index in both cases


def simulation(case, overrides=(), world=None):
    from runhelp import set_up
    return set_up(case, overrides, world)


def momentum(sim, world=None):
    p, fem = sim.particles, sim.elements
    local = p.mass @ p.v
    if fem is not None:
        local = local + fem.mass[fem.owned] @ fem.v[fem.owned]
    return world.sum(local) if world else local


def total_mass(sim):
    fem = sim.elements
    mass = sim.particles.mass.sum()
    return mass + (fem.mass[fem.owned].sum() if fem is not None else 0.0)


def run(sim, end, every=None, cfl=0.5):
    while sim.time < end - 1e-12:
        dt = min(cfl * sim.grid.h / sim.fastest_speed(), end - sim.time)
        sim.advance(dt)
        if every:
            every(sim)


def dropped(case, end):
    """The drop run to ``end``, with the weight's velocity after every step."""
    sim = simulation(case)
    start, mass = momentum(sim), total_mass(sim)
    history = []
    run(sim, end, every=lambda s: history.append(s.rigid_particles.velocity[WEIGHT].copy()))
    return sim, start, mass, np.array(history)


@pytest.fixture(scope="module")
def on_block():
    return dropped(ON_BLOCK, END)


@pytest.fixture(scope="module")
def on_plate():
    return dropped(ON_PLATE, PLATE_END)


def weight_particles(sim):
    p = sim.particles
    return p.body == WEIGHT


def test_on_a_block_the_free_axis_keeps_the_momentum_through_the_contact(on_block):
    """z momentum of block + weight = P0 - M g t to round-off (measured 1.8e-13 of the
    initial -3.07 kg m/s) through a blow that slowed the weight from -2.10 m/s (with
    gravity) to -1.39 m/s and threw the elastic block down at -2.56 m/s. Without the
    weight taking the impulses (a held rigid body) the sum would be off by its whole
    change, 1.1 kg m/s. (Before the bodies whose mass at a node is below the contact's
    threshold were counted, one step lost 1.2e-11.)"""
    sim, start, mass, history = on_block
    expected = start[2] - mass * G * sim.time
    assert abs(momentum(sim)[2] - expected) < 1e-12 * abs(start[2])
    assert history[:, 2].min() < -2.09              # free fall before the blow
    v = sim.rigid_particles.velocity[WEIGHT]
    assert -1.45 < v[2] < -1.3
    block = sim.particles.v[sim.particles.body == 0, 2].mean()
    assert block < -2.3                             # the elastic block took the blow


def test_on_a_block_held_axes_stay_and_every_particle_takes_the_body_velocity(on_block):
    """Friction pushed the weight along x (the elastic block lost x momentum: from
    0.26 kg m/s to 0.025), yet its x and y velocities are exactly 0; all its particles
    share one velocity, its body's."""
    sim, start, _, history = on_block
    v = sim.particles.v[weight_particles(sim)]
    assert (v == sim.rigid_particles.velocity[WEIGHT]).all()
    assert (history[:, :2] == 0.0).all()
    assert momentum(sim)[0] < 0.2 * start[0]


def test_on_a_block_positions_follow_the_body_velocity(on_block):
    """The weight's particles keep their relative places (a rigid translation), moved
    down by more than a cell."""
    sim, _, _, _ = on_block
    fresh = simulation(ON_BLOCK)
    mine, theirs = sim.particles, fresh.particles
    a = mine.x[weight_particles(sim)][np.argsort(mine.id[weight_particles(sim)])]
    b = theirs.x[weight_particles(fresh)][np.argsort(theirs.id[weight_particles(fresh)])]
    shift = a - b
    assert np.abs(shift - shift[0]).max() < 1e-12
    assert shift[0, 2] < -0.02 and (shift[:, :2] == 0).all()


def test_on_an_fem_plate_the_free_axis_keeps_the_momentum(on_plate):
    """Grid coupling: the FE nodes of the plate are the partners. z momentum of plate +
    weight = P0 - M g t to round-off (measured 1.4e-15 of -3.07 kg m/s); the weight,
    slowed by the plate from -2.05 m/s to -1.35 m/s, stays at 0 in x and y while the
    plate, sliding along x under it, lost half its x momentum (0.51 -> 0.24 kg m/s)."""
    sim, start, mass, history = on_plate
    expected = start[2] - mass * G * sim.time
    assert abs(momentum(sim)[2] - expected) < 1e-12 * abs(start[2])
    assert -1.45 < sim.rigid_particles.velocity[WEIGHT, 2] < -1.25
    assert (history[:, :2] == 0.0).all()
    assert (sim.particles.v[weight_particles(sim)]
            == sim.rigid_particles.velocity[WEIGHT]).all()
    assert momentum(sim)[0] < 0.6 * start[0]


def test_a_restart_continues_identically(tmp_path):
    """A checkpoint taken in the middle of the blow (0.012 s), read back into a new
    simulation, continues to the same weight velocity and particle state bit for bit:
    the body's velocity is its particles'."""
    from mpi4py import MPI
    from pmpm.comm import World
    from pmpm.io.checkpoint import load_checkpoint, save_checkpoint
    from pmpm.case.loader import load_config
    from pmpm.solver.simulation import Simulation
    cut, whole = simulation(ON_BLOCK), simulation(ON_BLOCK)
    for sim in (cut, whole):
        run(sim, 0.012)             # both end a step there
    scalars = {"time": cut.time, "step": cut.step_count, **cut.restart_state()}
    path = save_checkpoint(tmp_path, MPI.COMM_SELF, scalars, cut.particles.columns())
    del cut
    scalars, columns = load_checkpoint(path, MPI.COMM_SELF)
    resumed = Simulation.from_checkpoint(World(MPI.COMM_SELF), load_config(ON_BLOCK, []),
                                         scalars, columns)
    for sim in (resumed, whole):
        run(sim, 0.014)
    assert (resumed.rigid_particles.velocity == whole.rigid_particles.velocity).all()
    assert resumed.step_count == whole.step_count
    a, b = resumed.particles, whole.particles
    order_a, order_b = np.argsort(a.id), np.argsort(b.id)
    assert (a.x[order_a] == b.x[order_b]).all() and (a.v[order_a] == b.v[order_b]).all()


WEDGE = os.path.join(os.path.dirname(HERE), "runs", "wedge_entry.yaml")
#: the falling wedge (seed 004 Sec. 4.4) as a free rigid particle body in grid contact
#: with the water, coarse (40 mm cells, 2 particles per cell per direction)
PARTICLE_WEDGE = ["params.cell=40.0", "params.ppc=2", "params.method=1",
                  "bodies[0].method=particles", "bodies[0].fem={}",
                  "bodies[0].particles_per_cell=2"]
WEDGE_END = 12.0                                 # ms


def wedge_run(overrides=()):
    sim = simulation(WEDGE, PARTICLE_WEDGE + list(overrides))
    p = sim.particles
    start = p.mass @ p.v[:, 1]
    v0 = sim.rigid_particles.velocity[0, 1]
    run(sim, WEDGE_END)
    return sim, start, v0


def test_the_particle_wedge_gives_the_water_the_momentum_it_loses():
    """Gravity off, in a tank twice as wide and deep (the floor and walls out of the
    entry's reach, as in tests/test_wedge.py): wedge + water keep their y momentum
    (measured 2e-13 of it) while the wedge loses 16 % of its speed by 12 ms."""
    sim, start, v0 = wedge_run(["params.g=0.0", "params.width=4000.0",
                                "params.depth=2000.0"])
    p = sim.particles
    assert abs(p.mass @ p.v[:, 1] - start) < 1e-11 * abs(start)
    assert sim.rigid_particles.velocity[0, 1] > 0.9 * v0          # slower (v < 0)


def test_the_particle_wedge_slows_near_von_karman():
    """With gravity the wedge slows from 6.15 m/s to 5.26 m/s at 12 ms, 7.6 % below von
    Karman's momentum balance (5.69; pmpm.post.fsi.momentum_theory): the grid contact
    meets the water up to a cell before the surfaces touch, and a cell is 40 mm here.
    At 20 mm cells and 4 particles per cell per direction the run gives 5.51 (-3.2 %;
    docs/validation/wedge_entry.md). Tolerance 10 %."""
    from pmpm.post import fsi
    sim, _, _ = wedge_run()
    speed = -sim.rigid_particles.velocity[0, 1]
    _, v = fsi.momentum_theory(1.0, end=WEDGE_END)
    assert speed == pytest.approx(float(v[-1]), rel=0.10)
    assert speed < 0.95 * (6.15 + 9.81 * WEDGE_END * 1e-3)
    assert (sim.rigid_particles.velocity[0, [0, 2]] == 0.0).all()


@pytest.mark.parametrize("override, message", [
    ("contact.method=none", "needs grid contact (contact.method 1 or 2)"),
    ("materials.heavy={model: elastic, density: 4000.0, E: 1.0e9, nu: 0.3}",
     "not a rigid one"),
    ("bodies[1].velocity=[0, 0, '-2 * x']", "uniform initial velocity"),
])
def test_refusals_name_the_key(override, message):
    with pytest.raises(CaseError) as caught:
        load_case(ON_BLOCK, [override])
    assert any(line.startswith("bodies[1].rigid.free") and message in line
               for line in caught.value.problems)


def slot_records(masses, momenta, forces, new):
    """A ContactSlots of one slot with these per-body masses, momenta, forces and end
    accelerations (start velocities = momentum / mass)."""
    from pmpm.kernels.records import ContactSlots
    nb = len(masses)
    cnodal = np.zeros((1, nb, 10))
    cnodal[0, :, 0] = masses
    cnodal[0, :, 1:4] = momenta
    cvel = np.asarray(momenta, float)[None] / np.asarray(masses, float)[None, :, None]
    cnew = np.zeros((1, nb, 6))
    cnew[0, :, 3:] = new
    return ContactSlots(cnodal, np.zeros(1, np.int64), cvel, np.zeros((1, nb, 3)),
                        np.asarray(forces, float)[None], cnew)


def test_the_partners_impulse_goes_to_the_rigid_bodies_by_their_mass_at_the_node():
    """One node: deformable body 0 (mass 2, own force (0, 0, -4), end acceleration
    (0, 0, 3): impulse 2 (3 + 2) dt = 10 dt in z), a deformable body 1 of mass 1e-20
    (below any contact threshold; its force 1e-3 is lost to the node, which moves it
    with the rigid velocity: its impulse is -1e-3 dt) and two rigid bodies of masses 3
    (free) and 1 (held): the free one gets 3/4 of the sum, the held one nothing."""
    from pmpm.kernels.forces import rigid_partner_impulses
    slots = slot_records([2.0, 1e-20, 3.0, 1.0], np.zeros((4, 3)),
                         [[0, 0, -4.0], [0, 0, 1e-3], [0, 0, 0], [0, 0, 0]],
                         [[0, 0, 3.0], [0, 0, 0], [0, 0, 0], [0, 0, 0]])
    out = np.zeros((4, 3))
    dt = 0.5
    rigid_partner_impulses(slots, slots.cnodal[:, :, 0].copy(), np.zeros(4),
                           np.array([False, False, True, True]),
                           np.array([False, False, True, False]), np.zeros(1, np.uint16),
                           np.ones(1, np.bool_), 1, dt, out)
    assert out[2] == pytest.approx([0, 0, 0.75 * (10.0 - 1e-3) * dt], rel=1e-14)
    assert (np.delete(out, 2, axis=0) == 0).all()


def test_a_node_without_a_free_rigid_body_gives_it_nothing():
    """The same node with the held rigid body alone: the impulse goes to its support."""
    from pmpm.kernels.forces import rigid_partner_impulses
    slots = slot_records([2.0, 1.0], np.zeros((2, 3)), [[0, 0, -4.0], [0, 0, 0]],
                         [[0, 0, 3.0], [0, 0, 0]])
    out = np.zeros((2, 3))
    rigid_partner_impulses(slots, slots.cnodal[:, :, 0].copy(), np.zeros(2),
                           np.array([False, True]), np.array([False, False]),
                           np.zeros(1, np.uint16), np.ones(1, np.bool_), 1, 0.5, out)
    assert (out == 0).all()


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("case, end, axis", [(ON_BLOCK, END, "x"),
                                              (ON_PLATE, PLATE_END, "x")])
def test_n_ranks_give_the_one_rank_answer(case, end, axis):
    """Slabs along x cut both bodies and the contact patch; each rank adds the impulses
    of the nodes it counts. With exact sums (auto turns them on here) the nodes' values
    are the 1-rank bits and the impulses are added exactly over the ranks, so the body's
    velocity and every particle's position are bitwise the 1-rank answer (without, the
    ranks' sums are added in rank order: round-off apart, every rank alike)."""
    from mpi4py import MPI
    from pmpm.comm import World
    world = World(MPI.COMM_WORLD)
    overrides = [f"decomposition.axis={axis}"]
    sims = {"n": simulation(case, overrides, world), "one": simulation(case, overrides)}
    for sim in sims.values():
        run(sim, end)
    assert sims["one"].config.grid.exact_sums
    v_n = sims["n"].rigid_particles.velocity
    v_1 = sims["one"].rigid_particles.velocity
    assert (np.concatenate(world.allgather(v_n[None])) == v_n).all()   # every rank alike
    assert (v_n == v_1).all()
    p_n, p_1 = momentum(sims["n"], world), momentum(sims["one"])
    assert np.abs(p_n - p_1).max() < 1e-11
    ids = np.concatenate(world.allgather(sims["n"].particles.id))
    x = np.concatenate(world.allgather(sims["n"].particles.x))[np.argsort(ids)]
    one = sims["one"].particles
    assert (x == one.x[np.argsort(one.id)]).all()
