"""pytest-mpi (2 ranks): the rebalance counts FEM elements with their weight (issue 24).
The particle block lies left of the FEM plate along x; the elements are made dearer (a
weight of 8) and the slabs rebalanced: the plane moves to where the particles plus the
weighted elements balance best, the elements migrate to their new slab's rank, and the
run, rebalanced every 10 steps, ends where the 1-rank run does to round-off.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_work_weights_mpi.py"""
import numpy as np
import pytest

from test_surface_contact import run, simulation
from test_surface_contact_mpi import comm_world, state
from test_work_weights import BESIDE, side_work

#: thrown at the plate's left end (x 0.14), which it reaches and touches
THROWN = BESIDE + ["params.vx=3.0", "params.vz=-2.0", "time.end=0.02"]


def points_on_slab_axis(sim, world):
    """Coarse cells along the slab axis and weights of every particle and element, over
    all ranks (the elements with their body's weight now)."""
    mine = [(k.slab_cells(sim.grid, sim.slabs.axis),
             np.ones(k.n) if k.slab_weights() is None else k.slab_weights())
            for k in sim.kinds + [sim.elements]]
    every = world.allgather(mine)
    cells = np.concatenate([c for part in every for c, _ in part])
    weights = np.concatenate([w for part in every for _, w in part])
    return cells, weights


@pytest.mark.mpi(min_size=2, max_size=2)
def test_the_rebalance_balances_weighted_work_and_two_ranks_match_one():
    world = comm_world()
    sims = {"two": simulation(THROWN, world), "one": simulation(THROWN)}
    for sim in sims.values():
        sim.elements.weight_of_body[sim.elements.body_indices] = 8.0
    two = sims["two"]
    before = int(two.slabs.bounds[1])
    imbalance, moved = two.rebalance(0.01)
    assert moved and imbalance > 0.1
    cut = int(two.slabs.bounds[1])
    assert cut > before                       # dearer elements: the plane moves right
    cells, weights = points_on_slab_axis(two, world)
    n = int(two.grid.n_cells[0])
    gap = [abs(np.subtract(*side_work(c, cells, weights, n))) for c in range(1, n)]
    assert gap[cut - 1] == min(gap)
    assert two.imbalance() < 0.1
    # every element now lies on its slab's rank
    mine = two.elements.slab_cells(two.grid, 0)
    lo, hi = two.slabs.owned(world.rank)
    assert ((mine >= lo) & (mine < hi)).all() and world.sum(two.elements.n_elements) == 288
    pairs = []

    def every(s):
        pairs.append(s.surface.last_pairs)
        if len(pairs) % 10 == 0:
            s.rebalance(0.01)
            s.sort_by_cell()
    for sim in sims.values():
        pairs.clear()
        run(sim, 0.02, every=every)
    assert sum(pairs) > 0                     # the block did meet the plate
    for (ids, x, v), (ids1, x1, v1) in zip(state(two, world), state(sims["one"], None)):
        assert (ids == ids1).all()
        assert np.abs(x - x1).max() < 1e-10 and np.abs(v - v1).max() < 1e-10
