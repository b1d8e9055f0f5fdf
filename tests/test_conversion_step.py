"""Conversion on the time step (``fem.convert.step_ratio``, pmpm.solver.conversion):
an element whose shape cuts its stable step below a share of the background cell's step
(an undistorted cube one cell wide of the body's material) becomes particles, so that
one distorted element does not set a collapsing step for the whole run, and the floor
does not depend on the mesh's smallest element (docs/validation/ogive_plate_fem.md)."""
import os

import numpy as np
import pytest

from pmpm.solver.conversion import cell_rates
from pmpm.solver.fem_bodies import initial_waves
from runhelp import set_up

HERE = os.path.dirname(os.path.abspath(__file__))
TAYLOR = os.path.join(HERE, "cases", "fem_taylor_convert.yaml")
#: plastic strain never converts here: only the step does
NO_STRAIN = ["bodies[0].fem.convert.eps_p=100"]


def totals(sim):
    p, fem = sim.particles, sim.elements
    m, v = fem.mass[fem.owned], fem.v[fem.owned]
    return np.concatenate([[p.mass.sum() + m.sum()], p.mass @ p.v + m @ v])


def test_the_flattened_bottom_layer_converts_and_nothing_else():
    """The bar's elements (1.3-1.52 mm) start with steps of at least 0.62 of the
    1.52 mm cell's. The nodes on top of its bottom layer of elements (25.4 / 17 mm high)
    are lowered to 0.5 mm (as the next force pass sees them): those elements' steps fall
    to 0.41-0.46 of the cell's (their width and the hourglass damping still count), the
    layer above grows taller (a longer step). With step_ratio 0.5 exactly the bottom
    layer converts, mass and momentum kept to round-off."""
    sim = set_up(TAYLOR, NO_STRAIN + ["bodies[0].fem.convert.step_ratio=0.5"])
    fem = sim.elements
    top = np.unique(np.round(fem.x[:, 2], 9))[1]
    bottom = fem.centroids()[:, 2] < top
    layer = np.abs(fem.x[:, 2] - top) < 1e-9
    assert bottom.any() and layer.any()
    limit = sim.conversion.cell_rates[0] / 0.5
    assert np.all(fem.shape_rates() < limit)        # nothing converts undistorted
    fem.x[layer, 2] = 0.5
    flat = fem.shape_rates()
    assert np.all(flat[bottom] > limit) and np.all(flat[~bottom] < limit)
    assert sim.conversion.transfer() == 0           # no force pass yet: no step known
    fem.stress_and_forces(1e-9)                     # the step rates (no strain rate yet)
    before, n_bottom = totals(sim), int(bottom.sum())
    assert sim.conversion.transfer() == n_bottom
    assert fem.n_elements > 0 and np.all(fem.centroids()[:, 2] > 0.5)
    after = totals(sim)
    assert abs(after[0] - before[0]) < 1e-14 * before[0]
    assert np.abs(after[1:] - before[1:]).max() < 1e-13 * np.abs(before[1:]).max()
    assert sim.particles.n == 8 * n_bottom


def test_without_the_key_the_flattened_layer_stays():
    sim = set_up(TAYLOR, NO_STRAIN)
    fem = sim.elements
    top = np.unique(np.round(fem.x[:, 2], 9))[1]
    fem.x[np.abs(fem.x[:, 2] - top) < 1e-9, 2] = 0.5
    fem.stress_and_forces(1e-9)
    assert sim.conversion.transfer() == 0


def smallest_step(overrides, end=0.03):
    """(cell's step at cfl 0.5, smallest step before the last, elements converted) of
    the Taylor bar run to ``end`` ms at cfl 0.5."""
    sim = set_up(TAYLOR, NO_STRAIN + list(overrides))
    steps = []
    while sim.time < end - 1e-12:
        dt = min(0.5 * sim.grid.h / sim.fastest_speed(), end - sim.time)
        sim.advance(dt)
        steps.append(dt)
    cell_step = 0.5 / cell_rates(sim.elements, sim.grid.h)[0]
    return cell_step, min(steps[:-1]), sim.conversion.converted


def test_the_step_stays_above_the_ratio_of_the_cells():
    """The bar's foot spreads: without the criterion its step falls to 0.45 of the
    cell's by 30 us (0.725 of its first, which is 0.62 of the cell's); with step_ratio
    0.5 the foot's most distorted elements convert and the step stays at 0.5 of the
    cell's (within 3 %: the criterion compares the force pass's rates, which take the
    current wave speed, the run's step the fastest speed)."""
    cell_step, least, converted = smallest_step([])
    assert converted == 0 and least < 0.47 * cell_step
    cell_step, least, converted = smallest_step(["bodies[0].fem.convert.step_ratio=0.5"])
    assert converted > 0 and least > 0.97 * 0.5 * cell_step


def test_the_floor_does_not_depend_on_the_smallest_element():
    """Two meshes of the same ogive rod (head elements 2.3 and 5.7 mm; their shortest
    steps at rest differ 3.7 times) in the same 2 mm cells have the same reference step
    and so the same floor; the reference is the shape rate of an undistorted cube one
    cell wide (1.8 c / cell with the viscous hourglass form)."""
    from test_ogive_plate_fem import CASE
    rates, shortest = [], []
    for rod in (2.3, 5.7):
        sim = set_up(CASE, ["params.cell=2", "params.plate_element=2",
                            f"params.rod_element={rod}"])
        fem = sim.elements
        rates.append(sim.conversion.cell_rates)
        shortest.append(fem.shape_rates(initial=True)[fem.body == 0].max())
    assert (rates[0] == rates[1]).all() and (rates[0] > 0).all()
    assert shortest[0] > 2.5 * shortest[1]
    c = initial_waves(sim.elements.table)[1]
    assert np.allclose(rates[0] * 2.0 / c, 1.82, rtol=0.01)
    plate = sim.elements.shape_rates(initial=True)[sim.elements.body == 1].max()
    assert abs(plate / rates[0][1] - 1) < 0.01      # 2.02 mm plate elements: the cell's


def test_the_reference_follows_the_cell_not_the_elements():
    """The Taylor bar in 1.52 mm cells meshed at 1.52 and at 0.76 mm: the same
    reference; in 0.76 mm cells twice the rate (a step half as long)."""
    coarse = set_up(TAYLOR, NO_STRAIN + ["bodies[0].fem.convert.step_ratio=0.2"])
    fine = set_up(TAYLOR, NO_STRAIN + ["bodies[0].fem.convert.step_ratio=0.2",
                                      "bodies[0].fem.element_size=0.76"])
    assert fine.elements.n_elements > 4 * coarse.elements.n_elements
    assert (fine.conversion.cell_rates == coarse.conversion.cell_rates).all()
    assert np.allclose(cell_rates(coarse.elements, 0.76), 2 * coarse.conversion.cell_rates,
                       rtol=1e-12)


def test_elements_finer_than_the_floor_are_counted_in_a_warning(capfd):
    """0.76 mm elements in 1.52 mm cells start at about 0.3 of the cell's step: with
    step_ratio 0.5 every one is below the floor, and the set-up says so."""
    sim = set_up(TAYLOR, NO_STRAIN + ["bodies[0].fem.convert.step_ratio=0.5",
                                     "bodies[0].fem.element_size=0.76"])
    err = capfd.readouterr().err
    assert f"body 'bar': {sim.elements.n_elements} elements start" in err
    set_up(TAYLOR, NO_STRAIN + ["bodies[0].fem.convert.step_ratio=0.5"])
    assert "elements start" not in capfd.readouterr().err


@pytest.mark.parametrize("value", [0, 1.5, -0.2])
def test_a_step_ratio_outside_0_1_is_refused_naming_its_key(value):
    from pmpm.case.errors import CaseError
    from pmpm.case.loader import load_config
    with pytest.raises(CaseError, match="step_ratio"):
        load_config(TAYLOR, [f"bodies[0].fem.convert.step_ratio={value}"])


def test_a_restart_keeps_the_answer(tmp_path):
    """Stopped at 20 us (a frame of both runs, so their steps match) and continued
    from the checkpoint, the run converting on the step ends on the uninterrupted run's
    last history row, bit for bit (the reference comes from the case, not the mesh, so
    the converted elements before the restart do not change it)."""
    from clihelp import pmpm, read_history
    case = [TAYLOR, "--set", "bodies[0].fem.convert.eps_p=100",
            "--set", "bodies[0].fem.convert.step_ratio=0.5", "--set", "time.end=0.03",
            "--set", "output.frames=3", "--quiet"]
    whole, split = tmp_path / "whole", tmp_path / "split"
    stop = ["--set", "time.end=0.02", "--set", "output.frames=2"]
    for args in (case + ["--out", whole], case + ["--out", split] + stop,
                 case + ["--out", split, "--restart"]):
        done = pmpm(args, timeout=300)
        assert done.returncode == 0, done.stderr
    (header, one), (_, two) = read_history(whole), read_history(split)
    assert one[-1, header.index("time")] == 0.03
    assert (one[-1] == two[-1]).all()


def test_a_checkpoint_of_the_earlier_reference_is_read_and_its_entry_ignored():
    """Checkpoints written before the cell's step was the reference kept the body's
    shortest first step (``start_rates``); restoring one keeps the cell's."""
    sim = set_up(TAYLOR, NO_STRAIN + ["bodies[0].fem.convert.step_ratio=0.5"])
    state = sim.conversion.state()
    assert "start_rates" not in state
    reference = sim.conversion.cell_rates.copy()
    sim.conversion.restore(dict(state, start_rates=[1.0]))
    assert (sim.conversion.cell_rates == reference).all()
