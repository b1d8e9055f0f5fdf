"""pytest-mpi (2 or more ranks): node-to-surface contact between FEM bodies on N ranks
gives the 1-rank answer to round-off. The bars meet at the slab plane (the faces go to
the other rank as a halo, the impulses come back); the block on the plate is cut by the
plane, so slave nodes on its bottom are held by two ranks and their impulses, computed
on their lowest holder, reach both copies.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_fem_contact_mpi.py"""
import numpy as np
import pytest

from test_fem_contact import BARS, SLIDING, run, simulation
from test_surface_contact_mpi import comm_world


def nodes(sim, world):
    """(ids, x, v) of every FE node, each once, in id order (over ``world``'s ranks, or
    this rank's own run when None)."""
    fem = sim.elements
    mine = (fem.node_id[fem.owned], fem.x[fem.owned], fem.v[fem.owned])
    parts = world.allgather(mine) if world else [mine]
    ids = np.concatenate([p[0] for p in parts])
    order = np.argsort(ids)
    return tuple(np.concatenate([p[k] for p in parts])[order] for k in range(3))


CASES = {"bars": (BARS, ["decomposition.axis=x", "time.end=0.005"]),
         "sliding": (SLIDING, ["decomposition.axis=x", "time.end=0.004"])}


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("name", sorted(CASES))
def test_n_ranks_give_the_one_rank_answer(name):
    world = comm_world()
    case, sets = CASES[name]
    sims = [simulation(case, sets, world), simulation(case, sets)]
    fem = sims[0].elements
    if name == "bars":                     # the plane between the bars: one body a rank
        assert world.max(len(np.unique(fem.body))) == 1
    else:                                  # the plane cuts the block: shared slaves
        slaves = np.zeros(len(fem.x), bool)
        slaves[sims[0].node_contact.slaves] = True
        shared = sum(int(np.count_nonzero(slaves[idx] & (fem.node_body[idx] == 1)))
                     for _, idx in fem.partners)
        assert world.sum(shared) > 0
    pairs = [[], []]
    for sim, log in zip(sims, pairs):
        def every(s, log=log):
            log.append(s.world.sum(s.node_contact.last_pairs))
            if len(log) % 10 == 0:         # the slabs follow the work: elements migrate
                s.rebalance(0.01)           # and the faces and slaves are found again
        run(sim, every)
    assert pairs[0] == pairs[1] and max(pairs[0]) > 0
    many, one = nodes(sims[0], world), nodes(sims[1], None)
    assert (many[0] == one[0]).all()
    for k in (1, 2):
        assert np.abs(many[k] - one[k]).max() <= 1e-12 * np.abs(one[k]).max()


@pytest.mark.mpi(min_size=2)
def test_fem_bars_on_the_grid_n_ranks_give_the_one_rank_answer():
    """Both bars on the grid (AFEMP): the slab plane between them, so the contact nodes'
    two body fields are summed over it; rebalanced every 10 steps."""
    from test_fem_contact import ON_GRID, contact_count
    world = comm_world()
    sets = ON_GRID + ["decomposition.axis=x", "time.end=0.005"]
    sims = [simulation(BARS, sets, world), simulation(BARS, sets)]
    counts = [[], []]
    for sim, log in zip(sims, counts):
        def every(s, log=log):
            log.append(contact_count(s))
            if len(log) % 10 == 0:
                s.rebalance(0.01)
        run(sim, every)
    # (the slots of a shared plane count on both of its ranks: compare the steps)
    assert [c > 0 for c in counts[0]] == [c > 0 for c in counts[1]] and max(counts[1]) > 0
    many, one = nodes(sims[0], world), nodes(sims[1], None)
    assert (many[0] == one[0]).all()
    for k in (1, 2):
        assert np.abs(many[k] - one[k]).max() <= 1e-12 * np.abs(one[k]).max()
