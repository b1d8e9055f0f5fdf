"""The slabs' balance counts each FEM element with its cost in particle-steps
(pmpm.solver.work_weights, issue 24): the table's weights, the weighted histograms, and
the initial cut of a case with the particles on one side and the elements on the other."""
import os
from types import SimpleNamespace

import numpy as np
import pytest

from pmpm.solver import work_weights as ww

HERE = os.path.dirname(os.path.abspath(__file__))
PLATE_CASE = os.path.join(HERE, "cases", "block_on_fem_plate.yaml")
#: the block (x 0.04-0.12) left of the plate (x 0.14-0.62, 24 x 6 x 2 elements of 0.02),
#: the grid widened to hold it, slabs along x
BESIDE = ["decomposition.axis=x", "params.x_plate=0.14", "params.element=0.02",
          "grid.max=[0.8, 0.16, 0.16]", "grid.shape_functions=linear"]


def fem(element="reduced", hourglass="viscous"):
    """The part of a pmpm.case.FemConfig the weights read."""
    return SimpleNamespace(element=element, hourglass=hourglass)


@pytest.mark.parametrize("shape", sorted(ww.PARTICLE_STEP_S))
def test_weights_are_whole_quarters_from_the_measured_table(shape):
    """Every weight is a positive multiple of a quarter (exact sums in any order) within
    an eighth of the measured cost ratio."""
    for form in ww.ELEMENT_STEP_S:
        rigid = form == "rigid"
        spec = fem("assumed_strain") if form == "assumed_strain" else \
            fem(hourglass=form.split("_")[-1])
        w = ww.element_weight(spec, rigid, shape)
        assert w >= ww.QUANTUM and (w / ww.QUANTUM) == int(w / ww.QUANTUM)
        ratio = ww.ELEMENT_STEP_S[form] / ww.PARTICLE_STEP_S[shape]
        assert abs(w - ratio) <= ww.QUANTUM / 2 or (w == ww.QUANTUM and ratio < w)


def test_an_element_weighs_less_against_the_dearer_27_node_particles():
    """A gimp particle-step costs more than a hat's, so the same element weighs less
    against it; a rigid element, whose stress is not updated, weighs least."""
    for form in ("reduced_viscous", "reduced_stiffness", "assumed_strain"):
        spec = fem("assumed_strain") if form == "assumed_strain" else \
            fem(hourglass=form.split("_")[-1])
        assert ww.element_weight(spec, False, "gimp") < ww.element_weight(spec, False,
                                                                          "linear")
        assert ww.element_weight(spec, True, "linear") < ww.element_weight(spec, False,
                                                                           "linear")


def test_body_weights_count_a_particle_body_one():
    bodies = [SimpleNamespace(is_fem=False, fem=None),
              SimpleNamespace(is_fem=True, fem=fem()),
              SimpleNamespace(is_fem=True, fem=fem()),
              SimpleNamespace(is_fem=False, fem=None)]
    config = SimpleNamespace(bodies=bodies, grid=SimpleNamespace(shape_functions="linear"))
    w = ww.body_weights(config, np.array([False, False, True, True]))
    assert w[0] == 1.0 and w[3] == 1.0          # a rigid particle body still counts 1
    assert w[1] == ww.element_weight(fem(), False, "linear") > 1.0
    assert w[2] == ww.element_weight(fem(), True, "linear") < w[1]


def test_weighted_cell_histograms_sum_the_weights_per_layer():
    from pmpm.grid import CoarseGrid
    grid = CoarseGrid(np.zeros(3), 1.0, [4, 4, 4], {})
    x = np.array([[0.5, 0.5, 3.5], [0.7, 2.5, 3.5], [3.2, 2.5, 0.1]])
    hx, hy, hz = grid.cell_histograms(x, np.array([1.0, 2.5, 0.25]))
    assert hx.tolist() == [3.5, 0.0, 0.0, 0.25]
    assert hy.tolist() == [1.0, 0.0, 2.75, 0.0]
    assert hz.tolist() == [0.25, 0.0, 0.0, 3.5]
    assert grid.cell_histograms(x)[0].tolist() == [2, 0, 0, 1]


def side_work(bound, cells, weights, n_cells):
    """The weighted work left and right of the slab plane at cell ``bound``."""
    hist = np.bincount(cells, weights, minlength=n_cells)
    return hist[:bound].sum(), hist[bound:].sum()


def test_the_initial_cut_balances_the_weighted_work():
    """Particles on the left, elements on the right, two slabs along x: the plane lies
    where the particles plus the elements' weights balance best (no other plane comes
    closer), which is not where the plain counts would put it."""
    from pmpm.case import fill_body
    from pmpm.case.loader import load_config
    from pmpm.solver.bodies import BodyTable
    from pmpm.solver.simulation import Simulation
    config = load_config(PLATE_CASE, BESIDE)
    world = SimpleNamespace(size=2, rank=0)
    case_dir = os.path.dirname(PLATE_CASE)
    grid, filled, slabs, _, meshes = Simulation.lay_out(world, config, case_dir, fill_body)
    assert slabs.axis == 0
    x = np.concatenate([p for p, _ in filled])
    (b, mesh), = meshes.items()
    centroids = mesh.points[mesh.hexes].mean(axis=1)
    w = ww.body_weights(config, BodyTable(config).rigid)[b]
    assert w >= 1.5                           # an element-step is dear against the hats
    assert x[:, 0].max() < centroids[:, 0].min()       # they lie apart along x
    cells = grid.cells_of(np.concatenate([x, centroids]))[:, 0]
    weights = np.concatenate([np.ones(len(x)), np.full(len(centroids), w)])
    n = int(grid.n_cells[0])
    gap = [abs(np.subtract(*side_work(c, cells, weights, n))) for c in range(1, n)]
    cut = int(slabs.bounds[1])
    assert gap[cut - 1] == min(gap)
    assert gap[cut - 1] <= w * np.bincount(cells, minlength=n).max()
    plain = [abs(np.subtract(*side_work(c, cells, None, n))) for c in range(1, n)]
    assert int(np.argmin(plain)) + 1 < cut    # counted 1 each, the plane sits further left


def test_a_restart_on_more_ranks_cuts_from_the_weighted_elements_too():
    """A checkpoint's elements (every rank reads them all) join the particles' histogram
    by their centroids, whatever the order of its node rows, with their weight."""
    from pmpm.grid import CoarseGrid
    from pmpm.solver.simulation import checkpoint_histograms
    grid = CoarseGrid(np.zeros(3), 1.0, [4, 1, 1], {})
    unit = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                     [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
    x = np.concatenate([unit + [2, 0, 0], unit + [3, 0, 0]])      # cells 2 and 3 in x
    node_id = np.array([7, 3, 12, 5, 9, 0, 14, 2, 4, 1, 6, 8, 10, 11, 13, 15])
    rows = np.random.default_rng(1).permutation(16)                 # rows in any order
    groups = {"nodes": {"node_id": node_id[rows], "x": x[rows]},
              "elements": {"hexes": np.array([node_id[:8], node_id[8:]]),
                           "body": np.array([1, 1])}}
    config = SimpleNamespace(bodies=[SimpleNamespace(is_fem=False, fem=None),
                                     SimpleNamespace(is_fem=True, fem=fem())],
                             grid=SimpleNamespace(shape_functions="linear"))
    world = SimpleNamespace(sum=lambda h: h)
    particles = SimpleNamespace(x=np.array([[0.5, 0.5, 0.5], [0.2, 0.5, 0.5]]))
    bodies = SimpleNamespace(rigid=np.array([False, False]))
    hx = checkpoint_histograms(world, config, grid, bodies, particles, groups)[0]
    w = ww.element_weight(fem(), False, "linear")
    assert hx.tolist() == [2.0, 0.0, w, w]
    assert checkpoint_histograms(world, config, grid, bodies, particles, {})[0].tolist() \
        == [2, 0, 0, 0]
