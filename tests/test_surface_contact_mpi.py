"""pytest-mpi (2 or more ranks): particle-to-surface contact (ICFEMP) on N ranks gives the
1-rank answer to round-off, with the FEM plate and the particle block across the slab
plane, the elements' segments sent to the other rank as a halo, and the node impulses
summed in (node id, particle id) order on every holder.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_surface_contact_mpi.py"""
import numpy as np
import pytest

from test_surface_contact import run, simulation


def comm_world():
    from mpi4py import MPI
    from pmpm.comm import World
    return World(MPI.COMM_WORLD)


def state(sim, world):
    """Particles by id and FE nodes by id, over all ranks of ``world`` (None: this
    rank's own run): (ids, x, v) of each."""
    p, fem = sim.particles, sim.elements
    mine = (p.id, p.x, p.v, fem.node_id[fem.owned], fem.x[fem.owned], fem.v[fem.owned])
    parts = world.allgather(mine) if world else [mine]
    out = []
    for k in (0, 3):
        ids = np.concatenate([part[k] for part in parts])
        order = np.argsort(ids)
        out.append((ids[order],) + tuple(np.concatenate([part[k + j] for part in parts])
                                         [order] for j in (1, 2)))
    return out


CASES = {
    "thrown": ["decomposition.axis=x", "params.vx=3.0", "params.vz=-2.0", "time.end=0.03"],
    "sliding": ["decomposition.axis=x", "params.g=10.0", "params.z_floor=0.0",
                "params.gap=0.0", "params.vz=0.0", "params.vx=1.0", "time.end=0.06"],
}


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("shape", ["linear", "gimp"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_n_ranks_give_the_one_rank_answer(name, shape):
    """The thrown and the sliding block, rebalanced every 20 steps (the slab planes move
    with the block, elements migrate and their faces are found again). On 3 ranks this
    rebalance once made the middle slab one cell wide, and a GIMP particle then reached
    a node the other neighbour reached too; slabs are now 2 cells wide with the 27-node
    shapes (pmpm.comm.slabs.balanced_bounds)."""
    world = comm_world()
    overrides = CASES[name] + [f"grid.shape_functions={shape}"]
    overrides.append(overrides.pop(-2))           # time.end stays last
    sims = {"n": simulation(overrides, world), "one": simulation(overrides)}
    assert sims["n"].slabs.bounds[1] * sims["n"].grid.h - 0.2 < 0.12   # the plane cuts
    pairs = []
    for sim in sims.values():                      # the block (x 0.04-0.12 at the start)
        steps = [0]

        def every(s):
            steps[0] += 1
            pairs.append(s.surface.last_pairs)
            if steps[0] % 20 == 0:
                s.rebalance(0.01)
                s.sort_by_cell()
        run(sim, float(overrides[-1].split("=")[1]), every=every)
    n_state, one_state = state(sims["n"], world), state(sims["one"], None)
    assert world.sum(sum(pairs)) > 0
    for (ids, x, v), (ids1, x1, v1) in zip(n_state, one_state):
        assert (ids == ids1).all()
        assert np.abs(x - x1).max() < 1e-10 and np.abs(v - v1).max() < 1e-10
    # the elements really are spread over the ranks
    assert world.allgather(sims["n"].elements.n_elements).count(0) == 0
