"""The body kinds as one abstraction (pmpm.solver.kinds): the step asks each kind only
for what its capabilities declare, and the simulation's outputs are sums over the one
list of kinds."""
import os

import numpy as np
import pytest

from pmpm.solver.kinds import BodyKind

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = os.path.join(HERE, "cases")


def simulation(case, overrides=()):
    from runhelp import set_up
    return set_up(os.path.join(CASES, case), overrides)


def test_the_base_kind_declares_nothing_and_adds_nothing():
    kind = BodyKind()
    assert not (kind.on_grid or kind.owns_nodes or kind.follows_slabs or kind.rebalances)
    assert np.array_equal(kind.energies(), np.zeros(3)) and kind.body_stats(None) == {}
    assert kind.potential((0, 0, -9.8)) == 0.0 and kind.load_power(np.zeros((1, 3))) == 0.0
    assert kind.element_count() == 0 and kind.fault is None and kind.speed == 0.0


def test_the_step_sorts_particles_elements_and_grid_nodes_by_capability():
    """Surface coupling: the particles map to the grid and follow the slabs, the
    elements advance their own nodes and rebalance. Grid coupling adds the FE nodes as
    points of the grid, after the particles."""
    surface = simulation("block_on_fem_plate.yaml")
    step = surface.stepper
    assert step.kinds == [surface.points, surface.elements]
    assert step.grid_kinds == [surface.points] and step.moving_kinds == [surface.points]
    assert step.node_kinds == [surface.elements] == surface.rebalancing()
    grid = simulation("fem_grid_bounce.yaml")
    step = grid.stepper
    assert len(step.kinds) == 3 and step.kinds[:2] == [grid.points, grid.elements]
    assert step.grid_kinds == [grid.points, step.kinds[2]]
    assert step.node_kinds == [grid.elements] and step.moving_kinds == [grid.points]


@pytest.mark.parametrize("exact", [False, True])
def test_the_outputs_are_sums_over_the_kinds(exact):
    """Energies, potential and the element count add each kind's part: the elements'
    hourglass energy is counted in the internal energy and reported on its own. With
    exact sums (grid.exact_sums) a column is the correctly rounded sum of every term,
    so it may differ from the sum of the kinds' plain sums in the last bits."""
    sim = simulation("block_on_fem_plate.yaml", [f"grid.exact_sums={str(exact).lower()}"])
    assert sim.exact == exact
    for _ in range(3):
        sim.advance(1e-4 * sim.grid.h / sim.fastest_speed())
    parts = [np.asarray(kind.energies(), float) for kind in sim.stepper.kinds]
    e = sim.energies()
    same = (lambda value: pytest.approx(value, rel=1e-13)) if exact else (lambda value: value)
    assert e["kinetic"] == same(parts[0][0] + parts[1][0]) and e["kinetic"] > 0
    assert e["internal"] == same(parts[0][1] + (parts[1][1] + parts[1][2]))
    assert e["hourglass"] == same(parts[1][2]) and e["total"] == e["kinetic"] + e["internal"]
    g = (0.0, 0.0, -1e-2)
    assert sim.gravitational_potential(g) == same(sum(k.potential(g) for k in sim.stepper.kinds))
    assert sim.n_elements == sim.elements.element_count() > 0
