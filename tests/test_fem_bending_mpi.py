"""pytest-mpi (2 or more ranks): a body of assumed_strain elements (the obstacle
cantilever with 2 x 10 elements, tests/test_fem_bending.py) on N ranks gives the
1-rank answer to round-off: the slab plane cuts the beam, so elements on both ranks
share nodes while their hourglass forces carry the bending.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_fem_bending_mpi.py"""
import numpy as np
import pytest
from runhelp import CASES, set_up
from test_conversion_mpi import by_id, comm_world

OVERRIDES = ["params.R=2", "bodies[0].fem.element=assumed_strain", "decomposition.axis=y"]


def nodes(sim, world):
    fem = sim.elements
    return by_id(world, fem.node_id[fem.owned], fem.x[fem.owned], fem.v[fem.owned])


@pytest.mark.mpi(min_size=2)
def test_n_ranks_give_the_one_rank_answer_with_assumed_strain_elements():
    world = comm_world()
    case = f"{CASES}/obstacle_cantilever.yaml"
    sims = {"n": set_up(case, OVERRIDES, world), "one": set_up(case, OVERRIDES)}
    for sim in sims.values():
        while sim.time < 20.0 - 1e-12:
            sim.advance(min(0.5 * sim.grid.h / sim.fastest_speed(), 20.0 - sim.time))
    assert sims["n"].step_count == sims["one"].step_count > 100
    held = world.allgather(len(sims["n"].elements.hexes))
    assert min(held) > 0                      # elements on every rank
    n_rows, one_rows = nodes(sims["n"], world), nodes(sims["one"], None)
    assert (n_rows[0] == one_rows[0]).all()
    for a, b in zip(n_rows[1:], one_rows[1:]):
        assert np.abs(a - b).max() <= 1e-10 * max(np.abs(b).max(), 1.0)
    v = one_rows[2]
    assert np.abs(v[:, 0]).max() > 0.1       # it bends: 20 ms into the first swing
