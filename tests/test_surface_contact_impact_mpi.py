"""pytest-mpi (2 or more ranks): the sphere on the FEM block (issue 24) on N ranks gives
the 1-rank answer to round-off, with the slab plane through the contact patch (the phi
sums of the face nodes are summed on their lowest holder in (node id, particle id)
order). Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_surface_contact_impact_mpi.py"""
import numpy as np
import pytest

from test_surface_contact_impact import simulation, sphere_history
from test_surface_contact_mpi import comm_world


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("speed", [50.0, 150.0])
def test_n_ranks_give_the_one_rank_answer_through_the_impact(speed):
    """At 150 m/s the sphere's lowest layer crosses a node plane under the surface nodes'
    ramp (pmpm.kernels.surface_contact.surface_nodes)."""
    world = comm_world()
    sets = ["decomposition.axis=x", "time.end=0.012", f"params.v={speed}"]
    rows = [sphere_history(simulation(sets, w), end=0.012) for w in (world, None)]
    assert np.abs(rows[0] - rows[1]).max() < 1e-9 * np.abs(rows[1]).max()
