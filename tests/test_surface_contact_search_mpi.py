"""pytest-mpi (2 or more ranks): the fast layer at the thin plate (issue 24 Sec. 4,
tests/test_surface_contact_search.py) on N ranks gives the 1-rank answer to round-off,
the deepest centre (summary.json's surface_contact.largest_penetration) included, with
the layer and the plate cut by the slab plane.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_surface_contact_search_mpi.py"""
import numpy as np
import pytest

from test_surface_contact import run
from test_surface_contact_mpi import comm_world, state
from test_surface_contact_search import simulation


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("overrides", [[], ["params.mu=0.3",
                                              "bodies[1].velocity=[1.0, 0, -2.0]"]],
                         ids=["fast", "oblique"])
def test_n_ranks_give_the_one_rank_answer(overrides):
    """Fast: the layer found 9.3 mm behind the face. Oblique: 2 m/s down and 1 m/s
    along with friction, met and stopped within the radius (no centre gets in)."""
    world = comm_world()
    overrides = overrides + ["decomposition.axis=x"]
    sims = {"n": simulation(overrides, world), "one": simulation(overrides)}
    lo, hi = sims["n"].slabs.bounds[1] * sims["n"].grid.h + sims["n"].grid.origin[0], 0.08
    assert 0.0 < lo < hi                          # the plane cuts the layer
    for sim in sims.values():
        run(sim, 0.005, cfl=0.9)
    for (ids, x, v), (ids1, x1, v1) in zip(state(sims["n"], world), state(sims["one"], None)):
        assert (ids == ids1).all()
        assert np.abs(x - x1).max() < 1e-12 and np.abs(v - v1).max() < 1e-10
    deepest = sims["n"].surface.deepest_centre()
    assert abs(deepest - sims["one"].surface.deepest) < 1e-12
    assert deepest > 0.009 if not overrides[:-1] else deepest < 0.005
    assert world.allgather(sims["n"].elements.n_elements).count(0) == 0
