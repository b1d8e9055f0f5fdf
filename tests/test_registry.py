"""The parts of a run built from one registry keyed by the case's names
(pmpm.solver.registry): the couplings, the kinds they bring and the transfers are built
in registry order for what the case asks for, the step runs exactly them, a checkpoint
keeps the same scalars whatever the case, and a part added to the registry is called by
the step with nothing else changed."""
import os

import numpy as np
import pytest

from pmpm.solver import registry, simulation as simulation_module
from pmpm.solver.couplings import Coupling
from pmpm.solver.fem_bodies import FemBodies
from pmpm.solver.registry import COUPLING, KIND, KINDS, PARTS, TRANSFER, Entry
from pmpm.solver.transfer import Transfer

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = os.path.join(HERE, "cases")
QUIET = "output.forces=false"


def simulation(case, overrides=()):
    from runhelp import set_up
    return set_up(os.path.join(CASES, case), overrides)


def test_the_registry_names_each_part_once_with_its_case_key_and_a_known_role():
    names = [e.name for e in PARTS]
    assert len(set(names)) == len(names)
    assert all(e.key and e.role in (COUPLING, KIND, TRANSFER) for e in PARTS)
    assert names[-1] == "force_log"          # last: it reads the other couplings' fields
    assert names.index("grid_contact") < names.index("rigid_particles")
    keys = [e.kept.key for e in PARTS if e.kept]
    assert len(set(keys)) == len(keys)


def test_the_kinds_beyond_the_particles_are_keyed_by_their_bodies_method():
    """A kind exists only where some body has its method, right after the particles."""
    assert [(e.method, e.name) for e in KINDS] == [("fem", "elements")]
    particles = simulation("two_blocks.yaml", [QUIET])
    assert particles.elements is None and particles.stepper.kinds == [particles.points]
    fem = simulation("fem_taylor_convert.yaml", [QUIET])
    assert isinstance(fem.elements, FemBodies)
    assert fem.stepper.kinds == [fem.points, fem.elements]


@pytest.mark.parametrize("case, overrides, expected", [
    ("two_blocks.yaml", ["contact.method=none", QUIET], []),
    ("two_blocks.yaml", [QUIET], ["grid_contact"]),
    ("fem_taylor_convert.yaml", [QUIET], ["surface", "conversion"]),
    ("fem_grid_bounce.yaml", ["output.forces=true"], ["grid_contact", "grid_nodes",
                                                      "force_log"]),
])
def test_a_case_gets_the_parts_it_asks_for_in_registry_order(case, overrides, expected):
    """Every part the case asks for and no other, each an attribute of the simulation
    (None where not asked for); the step runs the couplings in registry order, the
    kinds a coupling brings after the particles and elements, and the transfers."""
    sim = simulation(case, overrides)
    assert list(sim.parts) == expected
    for entry in PARTS:
        assert getattr(sim, entry.name) is sim.parts.get(entry.name)
    roles = {e.name: e.role for e in PARTS}
    assert sim.stepper.couplings == [sim.parts[n] for n in expected if roles[n] == COUPLING]
    assert sim.stepper.transfers == [sim.parts[n] for n in expected if roles[n] == TRANSFER]
    brought = [sim.parts[n] for n in expected if roles[n] == KIND]
    assert sim.stepper.kinds[len(sim.stepper.kinds) - len(brought):] == brought
    assert all(isinstance(t, Transfer) for t in sim.stepper.transfers)


def test_a_checkpoint_keeps_every_kept_part_s_scalar_absent_or_not():
    plain = simulation("two_blocks.yaml", ["contact.method=none", QUIET]).restart_state()
    converting = simulation("fem_taylor_convert.yaml").restart_state()
    for entry in PARTS:
        if entry.kept:
            assert plain[entry.kept.key] == entry.kept.absent
            assert entry.kept.key in converting
    assert converting["convert"]["converted"] == 0 and converting["surface_deepest"] == 0.0


class CountingCoupling(Coupling):
    """A coupling that changes nothing and counts the hooks the step calls."""

    def __init__(self):
        self.calls = []

    def after_scatter(self, grids, kinds):
        self.calls.append("after_scatter")

    def after_mass_sum(self, grids, kinds):
        self.calls.append("after_mass_sum")

    def after_velocities(self, grids):
        self.calls.append("after_velocities")

    def after_forces(self, grids):
        self.calls.append("after_forces")

    def after_integrate(self, grids, dt):
        self.calls.append("after_integrate")

    def after_update_points(self, dt):
        self.calls.append("after_update_points")


def advance(sim, steps=3):
    for _ in range(steps):
        sim.advance(0.2 * sim.grid.h / sim.fastest_speed())
    return np.concatenate([sim.particles.x.ravel(), sim.particles.v.ravel()])


def test_a_coupling_added_to_the_registry_alone_is_called_by_the_step(monkeypatch):
    """One entry, no other change: the step calls its hooks in step order, and a
    coupling that does nothing leaves the answers bit for bit."""
    before = advance(simulation("two_blocks.yaml"))
    counting = Entry("counting", "test.counting", COUPLING, lambda setup: CountingCoupling())
    monkeypatch.setattr(simulation_module, "PARTS", registry.PARTS + (counting,))
    sim = simulation("two_blocks.yaml")
    assert sim.stepper.couplings[-1] is sim.counting
    after = advance(sim)
    assert np.array_equal(after, before)
    assert sim.counting.calls == 3 * ["after_scatter", "after_mass_sum", "after_velocities",
                                      "after_forces", "after_integrate",
                                      "after_update_points"]
