"""pytest-mpi (2 or more ranks): conversion on the time step (fem.convert.step_ratio) on
N ranks gives the 1-rank answer to round-off: every rank reads its elements' rates from
its own force pass and the reference (the cell's step) comes from the case, so the
same elements convert at the same step however the bar is cut.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_conversion_step_mpi.py"""
import numpy as np
import pytest

from test_conversion import run, simulation
from test_conversion_mpi import comm_world, state

ON_THE_STEP = ["decomposition.axis=x", "bodies[0].fem.convert.eps_p=100",
               "bodies[0].fem.convert.step_ratio=0.5"]


@pytest.mark.mpi(min_size=2)
def test_n_ranks_convert_on_the_step_as_one_rank():
    world = comm_world()
    sims = {"n": simulation(ON_THE_STEP, world), "one": simulation(ON_THE_STEP)}
    for sim in sims.values():
        run(sim, 0.03)
    assert (sims["n"].conversion.cell_rates == sims["one"].conversion.cell_rates).all()
    assert sims["n"].conversion.converted == sims["one"].conversion.converted > 0
    for n_rows, one_rows in zip(state(sims["n"], world), state(sims["one"], None)):
        assert len(n_rows[0]) == len(one_rows[0]) > 0
        assert (n_rows[0] == one_rows[0]).all()
        for a, b in zip(n_rows[1:], one_rows[1:]):
            assert np.abs(a - b).max() <= 1e-10 * max(np.abs(b).max(), 1.0)
