"""pytest-mpi (2 ranks): shared-plane sums, particle migration, and a distributed step
against the same problem stepped serially on COMM_SELF in the same process."""
import numpy as np
import pytest

from pmpm.comm import World, sum_shared_planes, migrate_store
from pmpm.comm.slabs import Slabs
from pmpm.grid import LocalBlock
from pmpm.case import CaseConfig, validate_case
from pmpm.particles import Particles


def comm_world():
    from mpi4py import MPI
    return World(MPI.COMM_WORLD)


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("halo", [0, 1])
def test_shared_planes_are_summed_once_and_agree(halo):
    world = comm_world()
    slabs = Slabs(0, np.linspace(0, 4 * world.size, world.size + 1).astype(int))
    block = LocalBlock.for_rank(slabs, world.rank, np.zeros(3, int),
                                np.array([4 * world.size - 1, 2, 2]), halo=halo)
    values = np.full((block.n_nodes, 2), float(world.rank + 1))
    sum_shared_planes(world, block.shared_planes, block.as_planes(values))
    planes = block.as_planes(values)
    shared = set()
    for neighbour, (first, stop) in block.shared_planes:
        assert stop - first == 2 * halo + 1
        assert np.all(planes[first:stop] == world.rank + 1 + neighbour + 1)
        shared.update(range(first, stop))
    interior = [i for i in range(planes.shape[0]) if i not in shared]
    assert np.all(planes[interior] == world.rank + 1)


@pytest.mark.mpi(min_size=2)
def test_migration_carries_every_column():
    world = comm_world()
    n = 10 + world.rank
    p = Particles.empty(n)
    p.id[:] = 1000 * world.rank + np.arange(n)
    p.x[:] = p.id[:, None] * np.array([1.0, 2.0, 3.0])
    p.stress[:] = p.id[:, None] + np.arange(6)
    p.body[:] = p.id % 3
    dest = (p.id % world.size).astype(np.int64)
    migrate_store(world, dest, p)
    q = p
    assert np.all(q.id % world.size == world.rank)
    assert np.allclose(q.x, q.id[:, None] * np.array([1.0, 2.0, 3.0]))
    assert np.allclose(q.stress, q.id[:, None] + np.arange(6))
    assert np.all(q.body == q.id % 3)
    assert world.sum(q.n) == sum(10 + r for r in range(world.size))


def _random_store(world, n, seed):
    rng = np.random.default_rng(seed + 7919 * world.rank)
    p = Particles.empty(n)
    for name, column in p.columns().items():
        p.replace_column(name, rng.integers(-2 ** 30, 2 ** 30, column.shape) / 7.0)
    p.id[:] = 1000000 * world.rank + np.arange(n)
    return p


def _destinations(world, p, case, seed):
    rng = np.random.default_rng(seed + 31 * world.rank)
    if case == "random":
        leave = rng.random(p.n) < 0.3
        return np.where(leave, rng.integers(0, world.size, p.n), world.rank).astype(np.int64)
    if case == "all_to_last":
        return np.full(p.n, world.size - 1, np.int64)
    return np.full(p.n, world.rank, np.int64)                   # "none": nothing moves


def _expected_after_migration(world, p, dest):
    """What rank ``world.rank`` must hold: the rows every rank sends it, by source rank,
    in their order on the source (the order the solver's answers depend on)."""
    sent = world.allgather([{name: column[dest == r] for name, column in p.columns().items()}
                            for r in range(world.size)])
    return Particles({name: np.concatenate([sent[source][world.rank][name]
                                            for source in range(world.size)])
                      for name in p.columns()})


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("case, sizes", [("random", (500, 300)), ("random", (0, 400)),
                                         ("all_to_last", (200, 100)), ("none", (50, 0))])
def test_migrate_store_keeps_rows_and_their_order(case, sizes):
    """One packed Alltoallv gives every rank the rows sent to it, by source rank and in
    their order on the source; a rank may start or end empty."""
    world = comm_world()
    n = sizes[world.rank % len(sizes)]
    p = _random_store(world, n, seed=len(case))
    dest = _destinations(world, p, case, seed=n)
    before = world.sum(p.n)
    expected = _expected_after_migration(world, p, dest)
    migrate_store(world, dest, p)
    assert world.sum(p.n) == before == world.sum(expected.n)
    for name, column in expected.columns().items():
        got = getattr(p, name)
        assert got.dtype == column.dtype and got.flags.c_contiguous
        assert np.array_equal(got, column), name
    if case == "all_to_last":
        assert p.n == (before if world.rank == world.size - 1 else 0)



@pytest.mark.mpi(min_size=2)
def test_repeated_migrations_move_rows_in_place():
    """Step after step a few rows near either end leave for the neighbours, as particles
    crossing the slab cuts do: each time every rank holds what the packed copies say
    (by source rank, in order), and from the second time on its columns stay in their
    buffers (moved in place, not copied)."""
    world = comm_world()
    p = _random_store(world, 600 + 50 * world.rank, seed=3)
    rng = np.random.default_rng(11 + world.rank)
    x_before = None
    for step in range(8):
        dest = np.full(p.n, world.rank, np.int64)
        ends = np.r_[0:10, p.n - 10:p.n]
        leaving = rng.choice(ends, 4, replace=False)
        dest[leaving] = (world.rank + rng.choice([-1, 1], 4)) % world.size
        expected = _expected_after_migration(world, p, dest)
        migrate_store(world, dest, p)
        for name, column in expected.columns().items():
            assert np.array_equal(getattr(p, name), column), (step, name)
        if x_before is not None:
            assert np.shares_memory(p.x, x_before), step
        x_before = p.x

def _fill_box(body, grid, case_dir):
    g, d = body["geometry"], grid["cell"] / body["particles_per_cell"]
    axes = [np.arange(g["min"][a] + d / 2, g["max"][a], d) for a in range(3)]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return x, np.full(len(x), d ** 3)


CASE = {
    "grid": {"min": [0, 0, 0], "max": [12, 8, 8], "cell": 1.0,
             "boundary": {"x-": "slip", "z-": "fixed"}},
    "materials": {"steel": {"model": "j2_power", "density": 7.85e-3, "E": 200e3, "nu": 0.3,
                            "A": 600.0, "B": 275.0, "n": 0.36,
                            "eos": {"type": "mie_gruneisen", "c0": 3600.0, "s": 1.9,
                                    "gamma0": 1.7}}},
    "bodies": [{"name": "block", "material": "steel", "particles_per_cell": 2,
                "velocity": [-150, 0, -100],
                "geometry": {"type": "box", "min": [2, 2, 0], "max": [10, 6, 4]}}],
}


def _step_all(world, steps=60, case=None):
    from pmpm.solver.simulation import Simulation
    case = {"time": {"end": 1.0}, **(case or CASE)}
    config = CaseConfig.from_case(validate_case(case, check_geometry=False))
    sim = Simulation.from_config(world, config, ".", _fill_box)
    dt = 0.4 / sim.initial_speed()
    for k in range(steps):
        sim.advance(dt)
        if k % 10 == 9:
            sim.rebalance(0.01)
            sim.sort_by_cell()
    return sim.particles


@pytest.mark.mpi(min_size=2)
def test_distributed_step_equals_serial_step():
    from mpi4py import MPI
    world = comm_world()
    mine = _step_all(world)
    serial = _step_all(World(MPI.COMM_SELF))
    ids = np.concatenate(world.allgather(mine.id))
    xs = np.concatenate(world.allgather(mine.x))
    order = np.argsort(ids)
    assert np.array_equal(ids[order], np.sort(serial.id))
    ref = serial.x[np.argsort(serial.id)]
    assert np.abs(xs[order] - ref).max() < 1e-10 * 12.0
    assert np.abs(ref - _fill_box(CASE["bodies"][0], CASE["grid"], ".")[0]).max() > 0.1


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("scheme", ["usf", "musl"])
def test_distributed_step_with_a_refined_window_equals_serial_step(scheme):
    """A window across the slab plane: ties on both ranks, the block's coarse particles
    inside it split after the first step, slabs rebalanced as the count grows; in both
    update orders."""
    import copy
    from mpi4py import MPI
    case = copy.deepcopy(CASE)
    case["grid"]["windows"] = [{"min": [4, 0, 0], "max": [9, 8, 5], "ratio": 2}]
    case["time"] = {"end": 1.0, "scheme": scheme}
    world = comm_world()
    mine = _step_all(world, case=case)
    serial = _step_all(World(MPI.COMM_SELF), case=case)
    ids = np.concatenate(world.allgather(mine.id))
    xs = np.concatenate(world.allgather(mine.x))
    order = np.argsort(ids)
    assert np.array_equal(ids[order], np.sort(serial.id))
    assert len(ids) > 1024 + 2000             # 1024 filled, 640 of them in the window split
    assert np.abs(xs[order] - serial.x[np.argsort(serial.id)]).max() < 1e-10 * 12.0

