"""pytest-mpi (2 or more ranks): with layer-ordered sums (grid.exact_sums: true)
N ranks give the 1-rank answer to the bit: the Taylor bar, its particles crossing the
slab planes, the slabs rebalanced and the particles re-sorted on the way, with the hats
and with gimp; the sphere rolling on the FEM plate (surface contact's grid sums, the
FE nodes the ranks share); refined windows tied to the coarse grid, one across the slab
plane with grid contact in it, one following a body across the slab plane; and a block
bouncing off a grid-coupled FEM plate (CFEMP). The control: summed in array order, the
same runs part in the last bits.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_exact_sums_mpi.py"""
import os

import numpy as np
import pytest

from runhelp import RUNS, set_up
from test_conversion_mpi import by_id, comm_world, state

CASE = os.path.join(RUNS, "taylor_bar.yaml")
ROLLING = os.path.join(RUNS, "sphere_rolling_fem.yaml")
COARSE = ["params.cell=1.52", "params.refined=4.56", "decomposition.axis=z"]
EXACT = ["grid.exact_sums=true"]
STEPS = 300


def stepped(sim, steps):
    """``steps`` steps of the run loop's CFL step, sorting and rebalancing as the run
    loop does (more often: every 10 steps)."""
    for step in range(1, steps + 1):
        sim.advance(0.5 * sim.grid.h / sim.fastest_speed())
        if step % 10 == 0:
            sim.sort_by_cell()
            sim.rebalance(0.02)


def run(overrides, world=None):
    """The state by particle id after STEPS steps of the run loop's CFL step, sorting
    and rebalancing as the run loop does (more often)."""
    sim = set_up(CASE, COARSE + overrides, world)
    start = sim.particles.x[:, 2].copy(), sim.particles.id.copy()
    stepped(sim, STEPS)
    p = sim.particles
    return sim, by_id(world, p.id, p.x, p.v, p.stress), by_id(world, start[1], start[0])


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("shape", ["linear", "gimp"])
def test_n_ranks_give_the_one_rank_answer_to_the_bit(shape):
    world = comm_world()
    sets = EXACT + [f"grid.shape_functions={shape}"]
    many, got, start = run(sets, world)
    _, expected, _ = run(sets)
    for a, b in zip(got, expected):
        assert np.array_equal(a, b)
    cells = [np.floor((z - many.grid.origin[2]) / many.grid.h) for z in (start[1], got[1][:, 2])]
    owner_then, owner_now = (many.slabs.owner_of_cells(c) for c in cells)
    assert (owner_then != owner_now).any()            # particles changed rank
    assert np.abs(got[3]).max() > 100.0               # a plastic impact (MPa)


@pytest.mark.mpi(min_size=2)
def test_summed_in_array_order_n_ranks_part_in_the_last_bits():
    world = comm_world()
    sets = []                     # the default: grid.exact_sums auto, off for one body
    _, got, _ = run(sets, world)
    _, expected, _ = run(sets)
    assert np.array_equal(got[0], expected[0])
    scale = np.abs(expected[1]).max()
    assert 0 < np.abs(got[1] - expected[1]).max() < 1e-10 * scale


def roll(overrides, world=None, steps=80):
    """Particles (id, x, v, eps_p) and owned FE nodes (id, x, v, mass) by id after
    ``steps`` steps of the rolling sphere, R = 4."""
    sim = set_up(ROLLING, ["params.R=4"] + overrides, world)
    for _ in range(steps):
        sim.advance(0.5 * sim.grid.h / sim.fastest_speed())
    return sim, state(sim, world)


@pytest.mark.mpi(min_size=2)
def test_the_sphere_on_the_fem_plate_rolls_on_n_ranks_as_on_one_to_the_bit():
    world = comm_world()
    many, got = roll([], world)                       # the default, auto: on here
    _, expected = roll([])
    for part, one in zip(got, expected):
        for a, b in zip(part, one):
            assert np.array_equal(a, b)
    assert many.slabs.size >= 2 and many.elements.partners       # FE nodes are shared
    assert np.abs(got[0][2]).max() > 0                           # the sphere moves


def spheres(overrides, world=None):
    """Particles (id, x, v) by id and the grid contact's slot count after 150 steps of
    two spheres meeting (tests/cases/hertz.yaml without its window: contact method 2,
    the release rule's volume gap, gimp, symmetry faces), slabs cut through both."""
    case = os.path.join(os.path.dirname(RUNS), "tests", "cases", "hertz.yaml")
    sim = set_up(case, ["params.ratio=1", "decomposition.axis=x"] + overrides, world)
    for _ in range(150):
        sim.advance(0.5 * sim.grid.h / sim.fastest_speed())
    contact, = (c for c in sim.stepper.couplings if hasattr(c, "n_slots"))
    return by_id(world, sim.particles.id, sim.particles.x, sim.particles.v), contact.n_slots()


@pytest.mark.mpi(min_size=2)
def test_grid_contact_across_the_slab_plane_is_exact_too():
    """The per-body mass, momentum, force and volume at the contact slots are
    layer-ordered too; summed in array order the same runs part."""
    world = comm_world()
    (got, slots), (expected, _) = spheres(EXACT, world), spheres(EXACT)
    for a, b in zip(got, expected):
        assert np.array_equal(a, b)
    assert slots > 0                                  # the spheres are in contact
    off = ["grid.exact_sums=false"]                  # auto is on where bodies touch
    (plain, _), (plain_one, _) = spheres(off, world), spheres(off)
    assert not np.array_equal(plain[2], plain_one[2])


HERTZ = os.path.join(os.path.dirname(RUNS), "tests", "cases", "hertz.yaml")
FOLLOW = os.path.join(os.path.dirname(RUNS), "tests", "cases", "window_follow.yaml")


def windowed(case, overrides, steps, world=None):
    """The simulation, the particles (id, x, v, stress) by id and their first ranks
    (id, rank) after ``steps`` steps of the run loop's CFL step, sorting and rebalancing
    every 10 steps; ``sim.first_window_lo``: the windows' first lower corners."""
    sim = set_up(case, overrides, world)
    sim.first_window_lo = [w.lo.copy() for w in sim.windows]
    start = ranks_by_id(sim, world)
    stepped(sim, steps)
    p = sim.particles
    return sim, by_id(world, p.id, p.x, p.v, p.stress), start


def ranks_by_id(sim, world):
    """(id, the rank holding it) of every particle."""
    p = sim.particles
    return by_id(world, p.id, np.full(p.n, world.rank if world else 0))


#: two spheres meeting inside a window refined twice that the slab plane cuts in two
#: (gimp, contact method 2, the release rule's volume gap; auto turns the sums on)
HERTZ_SETS = ["params.R=3", "params.gap=0.1", "decomposition.axis=z"]


@pytest.mark.mpi(min_size=2)
def test_a_window_with_contact_across_the_slab_plane_is_exact():
    world = comm_world()
    many, got, _ = windowed(HERTZ, HERTZ_SETS, 100, world)
    _, expected, _ = windowed(HERTZ, HERTZ_SETS, 100)
    for a, b in zip(got, expected):
        assert np.array_equal(a, b)
    a = many.slabs.axis
    cut = many.grid.origin[a] + many.slabs.bounds[1] * many.grid.h
    window = many.windows[0]
    assert window.lo[a] * many.grid.h + many.grid.origin[a] < cut < \
        window.hi[a] * many.grid.h + many.grid.origin[a]        # the cut runs through it
    contact, = (c for c in many.stepper.couplings if hasattr(c, "n_slots"))
    assert world.sum(contact.fields[1].n_slots) > 0       # the spheres touch in the window
    off = ["grid.exact_sums=false"]
    _, plain, _ = windowed(HERTZ, HERTZ_SETS + off, 100, world)
    _, plain_one, _ = windowed(HERTZ, HERTZ_SETS + off, 100)
    assert not np.array_equal(plain[2], plain_one[2])


@pytest.mark.mpi(min_size=2)
def test_a_window_that_follows_a_body_across_the_slab_plane_is_exact():
    """tests/cases/window_follow.yaml (the hats, contact method 2 on: auto turns the sums
    on): the cube and its window cross the slab plane, the plate's particles split."""
    world = comm_world()
    many, got, start = windowed(FOLLOW, [], 300, world)
    one, expected, _ = windowed(FOLLOW, [], 300)
    for a, b in zip(got, expected):
        assert np.array_equal(a, b)
    assert np.array_equal(many.refiner.centroids, one.refiner.centroids)   # by layers
    a = many.slabs.axis
    assert many.windows[0].lo[a] > many.first_window_lo[0][a]        # the window moved
    assert len(got[0]) > len(start[0])                     # particles were split
    end = ranks_by_id(many, world)
    _, now, then = np.intersect1d(end[0], start[0], return_indices=True)
    assert (end[1][now] != start[1][then]).any()           # particles changed rank
    _, plain, _ = windowed(FOLLOW, ["grid.exact_sums=false"], 300, world)
    _, plain_one, _ = windowed(FOLLOW, ["grid.exact_sums=false"], 300)
    assert not np.array_equal(plain[2], plain_one[2])


#: the steel ball in a window over the plate (the sets of
#: tests/test_shape_functions.py::test_tied_window_with_contact_matches_one_rank): the
#: plate's coarse particles end two cells below the slab plane, so only the rank below
#: holds the coarse nodes of the window's inner slaves there, which both ranks' window
#: blocks hold; and window_follow: the window crosses the slab plane
BSPLINE_WINDOWS = {
    "ball": (os.path.join(RUNS, "steel_ball_plate.yaml"),
             ["params.cell=2", "params.plate_radius=16", "params.cells_below=6",
              "params.ratio=2", "params.window=8", "params.window_below=4"], 100),
    "follow": (FOLLOW, [], 300),
}


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("name", sorted(BSPLINE_WINDOWS))
def test_windows_with_the_bspline_shapes_are_exact(name):
    """The 27-node shapes: window nodes beyond the faces tied, inner slaves (auto turns
    the sums on: contact method 2)."""
    world = comm_world()
    case, sets, steps = BSPLINE_WINDOWS[name]
    sets = sets + ["grid.shape_functions=bspline"]
    many, got, _ = windowed(case, sets, steps, world)
    _, expected, _ = windowed(case, sets, steps)
    for a, b in zip(got, expected):
        assert np.array_equal(a, b)
    assert world.sum(many.grids.windows[0].inner.count) > 0


BOUNCE = os.path.join(os.path.dirname(RUNS), "tests", "cases", "fem_grid_bounce.yaml")


def bounce(overrides, world=None, steps=150):
    """Particles (id, x, v, eps_p) and owned FE nodes (id, x, v, mass) by id after
    ``steps`` steps of the block bouncing off the grid-coupled FEM plate (CFEMP, method
    2; the FEM body turns the sums on), rebalancing every 10 steps."""
    sim = set_up(BOUNCE, ["params.tilt=0.5"] + overrides, world)
    for step in range(1, steps + 1):
        sim.advance(0.5 * sim.grid.h / sim.fastest_speed())
        if step % 10 == 0:
            sim.sort_by_cell()
            sim.rebalance(0.02)
    return sim, state(sim, world)


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("plate_end, more", [
    ("0.036", []), ("0.018", []), ("0.036", ["contact.release=0", "contact.gap=volume"])])
def test_grid_coupled_fe_nodes_are_exact(plate_end, more):
    """The FE nodes' mass, momentum, forces and contact fields on the grid (and with
    the release rule's volume gap their volumes) are summed as a part of their own
    (layer-ordered, by node id) and added to the particles' complete sums: the block and
    the plate on 2 ranks equal 1 rank bitwise, the plate spanning the slab plane (0.036)
    or ending on it (0.018: nodes lent to the upper rank); summed in array order they
    part."""
    world = comm_world()
    sets = [f"params.plate_end={plate_end}"] + more
    many, got = bounce(sets, world)
    _, expected = bounce(sets)
    for part, one in zip(got, expected):
        for a, b in zip(part, one):
            assert np.array_equal(a, b)
    assert many.grids.coarse.exact and many.slabs.size >= 2
    assert got[0][2][:, 2].max() > -2.0                      # the block hit the plate
    off = ["grid.exact_sums=false"]
    _, plain = bounce(sets + off, world)
    _, plain_one = bounce(sets + off)
    assert not all(np.array_equal(a, b) for a, b in zip(plain[0] + plain[1],
                                                         plain_one[0] + plain_one[1]))
