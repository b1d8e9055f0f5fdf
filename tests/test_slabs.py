"""Slab decomposition: balanced cuts, owner lookup, axis choice."""
import numpy as np
import pytest

from pmpm.comm.slabs import Slabs, balanced_bounds, choose_slabs


def test_balanced_bounds_split_equal_counts():
    counts = np.array([10, 10, 10, 10, 0, 0, 10, 10, 10, 10])
    bounds = balanced_bounds(counts, 2)
    assert bounds.tolist()[0] == 0 and bounds[-1] == 10
    per_rank = [counts[bounds[r]:bounds[r + 1]].sum() for r in range(2)]
    assert per_rank == [40, 40]


def test_every_rank_gets_at_least_one_cell():
    bounds = balanced_bounds(np.array([100, 0, 0, 0]), 4)
    assert np.all(np.diff(bounds) >= 1)


def test_owner_of_cells():
    slabs = Slabs(2, [0, 4, 9])
    assert slabs.owner_of_cells(np.array([0, 3, 4, 8])).tolist() == [0, 0, 1, 1]


def test_imbalance_measures_max_over_mean():
    slabs = Slabs(0, [0, 2, 4])
    assert slabs.imbalance(np.array([3, 3, 1, 1])) == 6 / 4 - 1


def test_choose_slabs_prefers_balanced_axis():
    hist = [np.array([50, 0, 0, 50]), np.array([25, 25, 25, 25]), np.array([100])]
    slabs = choose_slabs(hist, 2, "auto")
    assert slabs.imbalance(hist[slabs.axis]) == 0.0
    assert choose_slabs(hist, 2, "x").axis == 0


def test_exact_sums_cut_every_rank_count_along_the_axis_of_two():
    """With layer-ordered sums (``like_two_ranks``) ``auto`` takes the axis two ranks
    would cut on 1, 3 and 4 ranks too, where that axis admits them, so that every rank
    count adds in the same order; without, 4 ranks balance better along y."""
    hist = [np.array([30, 20, 25, 25, 0, 0]), np.array([25] * 4), np.array([100])]
    assert choose_slabs(hist, 2, "auto").axis == 0
    assert choose_slabs(hist, 4, "auto").axis == 1
    for ranks in (1, 3, 4):
        assert choose_slabs(hist, ranks, "auto", like_two_ranks=True).axis == 0
    assert choose_slabs(hist, 5, "auto", like_two_ranks=True).axis == 0
    assert choose_slabs(hist, 6, "auto", like_two_ranks=True).axis == 0


def test_slabs_for_27_node_shapes_are_at_least_three_cells_wide():
    """All the particles in one cell would give a one-cell middle slab; with min_width 3
    every slab keeps three cells (a particle reaches one node layer beyond its cell, and
    no node may be reached from both neighbours of a slab)."""
    from pmpm.comm.slabs import balanced_bounds
    counts = np.zeros(12)
    counts[6] = 1000
    counts[[0, 11]] = 1
    bounds = balanced_bounds(counts, 3, min_width=3)
    assert (np.diff(bounds) >= 3).all() and bounds[0] == 0 and bounds[-1] == 12
    assert (np.diff(balanced_bounds(counts, 3)) >= 1).all()
    with pytest.raises(ValueError):
        balanced_bounds(np.ones(8), 3, min_width=3)
