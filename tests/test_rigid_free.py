"""Free rigid FEM bodies (``rigid.free``, pmpm.solver.rigid_motion): a rigid block free in
z dropped on an elastic particle block (tests/cases/rigid_block_drop.yaml). Nothing
touches the grid's faces, so the z momentum of the two bodies grows by exactly
(total mass) g t through the contact, while the block's held x and y velocities stay
zero although friction pushes it along x. On 2 ranks (pytest-mpi) the answer is the
1-rank answer to round-off.
Run the MPI part with: mpirun -n 2 python -m pytest --with-mpi -m mpi tests/test_rigid_free.py"""
import os

import numpy as np
import pytest

from pmpm.case.errors import CaseError
from pmpm.case.loader import load_case

HERE = os.path.dirname(os.path.abspath(__file__))
CASE = os.path.join(HERE, "cases", "rigid_block_drop.yaml")
END = 0.018                 # contact from 0.010 s to 0.015 s (the blocks part again)


def simulation(overrides=(), world=None):
    from runhelp import set_up
    return set_up(CASE, overrides, world)


def momentum(sim, world=None):
    p, fem = sim.particles, sim.elements
    local = p.mass @ p.v + fem.mass[fem.owned] @ fem.v[fem.owned]
    return world.sum(local) if world else local


def total_mass(sim, world=None):
    fem = sim.elements
    local = sim.particles.mass.sum() + fem.mass[fem.owned].sum()
    return world.sum(local) if world else local


def run(sim, end, every=None, cfl=0.5):
    while sim.time < end - 1e-12:
        dt = min(cfl * sim.grid.h / sim.fastest_speed(), end - sim.time)
        sim.advance(dt)
        if every:
            every(sim)


@pytest.fixture(scope="module")
def dropped():
    """The drop run to END, with the contact pairs of every step."""
    sim = simulation()
    start, mass = momentum(sim), total_mass(sim)
    pairs = []
    run(sim, END, every=lambda s: pairs.append(s.surface.last_pairs))
    return sim, start, mass, pairs


def test_the_free_axis_keeps_the_momentum_through_the_contact(dropped):
    """z momentum of block + weight = P0 + M g t to round-off (measured 1e-13 of the
    initial 3.07 kg m/s), with up to 64 pairs a step acting on the weight, which was
    slowed from -2.1 m/s (with gravity) to -1.41 m/s; the particle block bounced off
    it at -2.1 m/s. (Later, at 0.0197 s, the particle block alone, in free flight,
    loses 4e-11 in one step: plain MPM's, not this test's, so END stops before.)"""
    sim, start, mass, pairs = dropped
    expected = start[2] - mass * 10.0 * sim.time
    assert max(pairs) >= 60
    assert abs(momentum(sim)[2] - expected) < 1e-11 * abs(start[2])
    v = sim.elements.rigid_motion.velocity[1]
    assert -1.5 < v[2] < -1.3
    blocks = sim.particles.v[:, 2].mean()
    assert blocks < -1.5                         # the particle block took the blow


def test_held_axes_stay_and_every_node_takes_the_body_velocity(dropped):
    """Friction pushed the weight along x (the particle block lost x momentum: from
    0.5 m/s to 0.18 m/s), yet its x and y velocities are exactly 0; all its nodes
    share one velocity, its body's."""
    sim, start, _, _ = dropped
    fem = sim.elements
    assert (fem.v[:, :2] == 0.0).all()
    assert (fem.v == sim.elements.rigid_motion.velocity[1]).all()
    assert momentum(sim)[0] < 0.6 * start[0]


def test_positions_follow_the_body_velocity(dropped):
    """The weight's nodes keep their relative places (a rigid translation)."""
    sim, _, _, _ = dropped
    fresh = simulation()
    shift = sim.elements.x - fresh.elements.x
    assert np.abs(shift - shift[0]).max() < 1e-12
    assert shift[0, 2] < -0.02 and (shift[:, :2] == 0).all()


class OneRank:
    """The one collective lent_inverse_mass calls, on one rank."""
    size = 1

    def sum(self, value):
        return value


@pytest.fixture(params=[False, True], ids=["plain_sums", "exact_sums"])
def exact(request):
    """Either way of summing the pairs' weights over the ranks (grid.exact_sums)."""
    return request.param


def bare_motion(free, mass, exact=False):
    """A RigidMotion of one body with these free axes and mass, without a case."""
    from pmpm.solver.rigid_motion import RigidMotion
    motion = RigidMotion.__new__(RigidMotion)
    motion.free, motion.mass, motion.world = np.array(free), np.array([mass]), OneRank()
    motion.exact = exact
    return motion


def test_a_single_pair_meets_the_whole_body_mass(exact):
    """One particle of mass m approaching a free rigid face at relative speed u along
    its normal n leaves with the body's velocity after one inelastic impulse
    m M / (m + M) u (its share of the body's mass is all of it): the lent inverse mass
    is |P n|^2 / M."""
    from pmpm.kernels import surface_contact as ksc
    motion = bare_motion([[False, False, True]], 3.0, exact)
    n = np.array([[0.0, 0.6, 0.8]])
    lent = motion.lent_inverse_mass(np.array([0]), n, np.zeros((1, 4)), np.array([2.8]))
    assert lent[0] == pytest.approx(np.full(4, 0.64 / 3.0))
    impulse = np.zeros(3)
    ksc.pair_impulse(2.0, np.array([0.0, -1.0, -1.0]), np.zeros((4, 3)), lent[0],
                     np.full(4, 0.25), n[0], 0.0, impulse)
    u = -1.4                                     # (v_p - v_c).n
    assert impulse == pytest.approx(2.0 / (1.0 + 2.0 * 0.64 / 3.0) * u * n[0])


def test_a_pair_that_cannot_move_the_body_takes_no_share_of_its_mass(exact):
    """Free in z only: a pair on a face with normal x (a wall of the body) cannot push it
    and meets it as rigid; the two pairs under it, pushing in z, share the whole mass
    (before, the wall pair's closing momentum took a third of it, and the two met only
    two thirds of the body: pushed to beyond their common velocity)."""
    motion = bare_motion([[False, False, True]], 6.0, exact)
    n = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    lent = motion.lent_inverse_mass(np.zeros(3, np.int64), n, np.zeros((3, 4)),
                                    np.array([1.0, 1.0, 1.0]))
    assert (lent[0] == 0.0).all()
    assert 1.0 / (6.0 * lent[1:, 0]) == pytest.approx([0.5, 0.5], rel=1e-12)


def test_pairs_share_the_body_mass_by_their_closing_momentum(exact):
    """Three pairs on one free body (two ranks' worth, summed by the world): each meets
    the share w_k / sum(w) of its mass; a pair barely closing meets almost none."""
    motion = bare_motion([[True, True, True]], 6.0, exact)
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    lent = motion.lent_inverse_mass(np.zeros(3, np.int64), n, np.zeros((3, 4)),
                                    np.array([1.0, 2.0, 1e-12]))
    shares = 1.0 / (6.0 * lent[:, 0])
    assert shares == pytest.approx([1 / 3, 2 / 3, 1e-12 / 3], rel=1e-9)


@pytest.mark.parametrize("override, message", [
    ("materials.heavy={model: elastic, density: 4000.0, E: 1.0e9, nu: 0.3}",
     "not a rigid one"),
    ("bodies[1].velocity=[0, 0, '-2 * x']", "uniform initial velocity"),
])
def test_refusals_name_the_key(override, message):
    with pytest.raises(CaseError) as caught:
        load_case(CASE, [override])
    assert any(line.startswith("bodies[1].rigid.free") and message in line
               for line in caught.value.problems)


@pytest.mark.mpi(min_size=2)
def test_n_ranks_give_the_one_rank_answer():
    """Slabs along z cut the particle block in two: half its particles and all the
    weight's elements on rank 1, the other half on rank 0, whose grid sums across the
    plane differ from 1 rank's by round-off without exact sums; the body velocity is
    summed over all ranks in particle id order, and the pairs' weights exactly: with
    grid.exact_sums (auto turns it on here) the answers are bitwise equal."""
    from mpi4py import MPI
    from pmpm.comm import World
    world = World(MPI.COMM_WORLD)
    overrides = ["decomposition.axis=z"]
    sims = {"n": simulation(overrides, world), "one": simulation(overrides)}
    for sim in sims.values():
        run(sim, END)
    assert sims["one"].config.grid.exact_sums
    v_n = sims["n"].elements.rigid_motion.velocity
    v_1 = sims["one"].elements.rigid_motion.velocity
    assert (v_n == v_1).all()
    p_n, p_1 = momentum(sims["n"], world), momentum(sims["one"])
    assert np.abs(p_n - p_1).max() < 1e-11
    ids = np.concatenate(world.allgather(sims["n"].particles.id))
    x = np.concatenate(world.allgather(sims["n"].particles.x))[np.argsort(ids)]
    one = sims["one"].particles
    assert (x == one.x[np.argsort(one.id)]).all()
