"""pytest-mpi (2 or more ranks): the coarse FEM perforation (tests/test_ogive_plate_fem.py)
on N ranks gives the 1-rank answer to round-off through node-to-surface contact between
the rod and the plate, the plate's conversions (on both ranks: the slab plane runs
through the impact) and the particles' surface contact with the rod.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_ogive_plate_fem_mpi.py"""
import numpy as np
import pytest

from pmpm.solver.step_limit import ElementStepLimit
from test_conversion_mpi import comm_world, state
from test_ogive_plate_fem import run, simulation


def assert_same_rows(sims, world):
    """The N-rank run's rows (by id) equal the 1-rank run's: ids exactly, values to
    1e-10 of their largest."""
    for n_rows, one_rows in zip(state(sims["n"], world), state(sims["one"], None)):
        assert len(n_rows[0]) == len(one_rows[0]) > 0
        assert (n_rows[0] == one_rows[0]).all()
        for a, b in zip(n_rows[1:], one_rows[1:]):
            assert np.abs(a - b).max() <= 1e-10 * max(np.abs(b).max(), 1.0)


@pytest.mark.mpi(min_size=2)
def test_n_ranks_give_the_one_rank_answer_through_the_perforation():
    world = comm_world()
    overrides = ["decomposition.axis=x"]
    sims = {"n": simulation(overrides, world), "one": simulation(overrides)}
    for sim in sims.values():
        run(sim, 0.025)
    assert sims["n"].conversion.converted == sims["one"].conversion.converted > 0
    assert_same_rows(sims, world)
    born = world.allgather(int(sims["n"].particles.n))
    assert min(born) > 0                      # conversions on every rank
    limits = {}
    for key, sim in sims.items():            # summary.json's element_step_limit
        limit = ElementStepLimit(sim.world, sim.bodies.names)
        limit.observe(sim.elements, sim.time, sim.step_count, 0.0)
        limits[key] = limit.summary()
    one, n = limits["one"], limits["n"]
    assert n.pop("stable_step") == pytest.approx(one.pop("stable_step"), rel=1e-10)
    assert np.allclose(n.pop("centroid"), one.pop("centroid"), rtol=0, atol=1e-10)
    assert n == one and one["body"] in ("rod", "plate")


@pytest.mark.mpi(min_size=2)
def test_the_fine_rod_converts_its_tip_at_the_start_on_n_ranks_as_on_one():
    """The 2.3 mm rod in 4 mm cells with the rod's step_ratio at 0.4: 136 of its nose
    elements (the cap's, all around the axis) start with a step below 0.4 of the cell's
    (fem.convert.step_ratio's reference) and convert after the first force pass, on
    both ranks (the slab plane cuts the rod's axis); N ranks give the 1-rank answer to
    round-off through those conversions and the first contact. (The mesh keeps its
    elements near the head's size to the tip, so at the case's 0.2 none starts below.)"""
    world = comm_world()
    overrides = ["decomposition.axis=x", "params.rod_element=2.3",
                 "bodies[0].fem.convert.step_ratio=0.4"]
    sims = {"n": simulation(overrides, world), "one": simulation(overrides)}
    for sim in sims.values():
        run(sim, 0.005)
    assert (sims["n"].conversion.cell_rates == sims["one"].conversion.cell_rates).all()
    assert sims["n"].conversion.converted == sims["one"].conversion.converted >= 136
    assert_same_rows(sims, world)
    born = world.allgather(int(sims["n"].particles.n))
    assert min(born) > 0                      # the tip's particles on every rank


@pytest.mark.mpi(min_size=2)
def test_afemp_n_ranks_give_the_one_rank_answer():
    """Both bodies on the grid (AFEMP), the slab plane through the impact: the contact
    nodes' body fields summed over it, the plate's first conversions into its own
    particle body (pmpm.case.config.converted_bodies)."""
    from test_ogive_plate_fem import AFEMP
    world = comm_world()
    overrides = AFEMP + ["decomposition.axis=x"]
    sims = {"n": simulation(overrides, world), "one": simulation(overrides)}
    for sim in sims.values():
        run(sim, 0.04)   # the first conversions at 37 us
    assert sims["n"].conversion.converted == sims["one"].conversion.converted > 0
    assert_same_rows(sims, world)
