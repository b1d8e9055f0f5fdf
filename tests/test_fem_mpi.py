"""pytest-mpi (2 or more ranks): the sums over FE nodes that several ranks hold, and the
sharers found again after elements move.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_fem_mpi.py"""
import numpy as np
import pytest

from pmpm.case.hexmesh import box_mesh
from pmpm.comm import World
from pmpm.comm.shared_nodes import sum_shared_rows
from pmpm.solver.fem_partition import partition_mesh, shared_with


def comm_world():
    from mpi4py import MPI
    return World(MPI.COMM_WORLD)


def random_partition(world, seed):
    points, hexes = box_mesh([0, 0, 0], [4, 2, 2], [8, 2, 3])
    owner = np.random.default_rng(seed).integers(0, world.size, len(hexes))
    return points, hexes, partition_mesh(hexes, len(points), owner, world.rank, world.size)


@pytest.mark.mpi(min_size=2)
def test_shared_node_sums_are_the_global_sums_and_equal_on_every_sharer():
    """Each element adds a value of its own to its nodes; after the sum every rank holds,
    at each of its nodes, the sum over all elements, and the copies agree bit for bit."""
    world = comm_world()
    points, hexes, part = random_partition(world, 1)
    rng = np.random.default_rng(2)
    contribution = rng.normal(size=(len(hexes), 8, 2))
    expected = np.zeros((len(points), 2))
    np.add.at(expected, hexes, contribution)
    partial = np.zeros((len(part.nodes), 2))
    np.add.at(partial, part.hexes, contribution[part.elements])
    total = sum_shared_rows(world, partial, part.partners)
    assert np.abs(total - expected[part.nodes]).max() < 1e-13
    every = world.allgather((part.nodes, total))
    for ids, values in every:
        common, here, there = np.intersect1d(part.nodes, ids, return_indices=True)
        assert (total[here] == values[there]).all()


@pytest.mark.mpi(min_size=2)
def test_sharers_found_from_node_ids_match_the_partition():
    world = comm_world()
    points, _, part = random_partition(world, 3)
    partners, owned = shared_with(world, part.nodes, points[part.nodes], 0.0)
    assert [r for r, _ in partners] == [r for r, _ in part.partners]
    assert all((a == b).all() for (_, a), (_, b) in zip(partners, part.partners))
    assert (owned == part.owned).all()


@pytest.mark.mpi(min_size=2)
def test_a_checkpoint_group_failing_on_one_rank_stops_every_rank(monkeypatch):
    """load_group raising on the last rank only: every rank raises InputError with its
    line (before, the others went on into the set-up's collectives and hung)."""
    from types import SimpleNamespace

    import pmpm.io
    from pmpm.app import InputError, read_checkpoint
    world = comm_world()

    def load_group(path, name):
        if world.rank == world.size - 1:
            raise OSError("unreadable on this rank")
        return {"x": np.zeros(1)}

    monkeypatch.setattr(pmpm.io, "load_checkpoint", lambda path, comm: ({}, {}))
    monkeypatch.setattr(pmpm.io, "load_group", load_group)
    config = SimpleNamespace(bodies=[SimpleNamespace(is_fem=True)])
    with pytest.raises(InputError) as error:
        read_checkpoint(world, "ck.h5", config)
    assert error.value.problems == ["--restart: cannot read checkpoint 'ck.h5': "
                                    "unreadable on this rank"]
