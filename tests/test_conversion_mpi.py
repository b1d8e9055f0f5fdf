"""pytest-mpi (2 or more ranks): element-to-particle conversion on N ranks gives the
1-rank answer to round-off: the Taylor bar's foot, cut by the slab plane, converts on
both ranks; shared nodes lose the converted elements' mass on every holder in element id
order, the particles are born with the same ids, and the surface contact meets the new
free faces on both sides.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_conversion_mpi.py"""
import numpy as np
import pytest

from test_conversion import run, simulation


def comm_world():
    from mpi4py import MPI
    from pmpm.comm import World
    return World(MPI.COMM_WORLD)


def by_id(world, ids, *columns):
    parts = world.allgather((ids,) + columns) if world else [(ids,) + columns]
    ids = np.concatenate([p[0] for p in parts])
    order = np.argsort(ids)
    return (ids[order],) + tuple(np.concatenate([p[k] for p in parts])[order]
                                 for k in range(1, len(columns) + 1))


def state(sim, world):
    p, fem = sim.particles, sim.elements
    return (by_id(world, p.id, p.x, p.v, p.eps_p),
            by_id(world, fem.node_id[fem.owned], fem.x[fem.owned], fem.v[fem.owned],
                  fem.mass[fem.owned]))


@pytest.mark.mpi(min_size=2)
def test_n_ranks_give_the_one_rank_answer_through_conversions():
    world = comm_world()
    overrides = ["decomposition.axis=x", "time.end=0.024"]
    sims = {"n": simulation(overrides, world), "one": simulation(overrides)}
    for sim in sims.values():
        steps = [0]

        def every(s):
            steps[0] += 1
            if steps[0] % 25 == 0:
                s.rebalance(0.01)
                s.sort_by_cell()
        run(sim, 0.024, every)
    n_state, one_state = state(sims["n"], world), state(sims["one"], None)
    assert sims["n"].conversion.converted == sims["one"].conversion.converted > 0
    for n_rows, one_rows in zip(n_state, one_state):
        assert len(n_rows[0]) == len(one_rows[0]) > 0
        assert (n_rows[0] == one_rows[0]).all()
        for a, b in zip(n_rows[1:], one_rows[1:]):
            assert np.abs(a - b).max() <= 1e-10 * max(np.abs(b).max(), 1.0)
    # the conversions happened on more than one rank
    born = world.allgather(int(sims["n"].particles.n))
    assert sum(born) > 0
    assert world.allgather(sims["n"].elements.n_elements).count(0) == 0
