"""Slab decomposition of the coarse grid along one axis, balanced by particle count."""
import numpy as np

from ..solver.errors import SetupError

AXES = "xyz"


class Slabs:
    """Rank ``r`` owns coarse cells ``bounds[r] <= c < bounds[r+1]`` along ``axis``.

    Nodes on the plane ``bounds[r]`` (0 < r < size) are shared by ranks r-1 and r.
    """

    def __init__(self, axis, bounds):
        self.axis = int(axis)
        self.bounds = np.asarray(bounds, dtype=np.int64)

    @property
    def size(self):
        return len(self.bounds) - 1

    def owner_of_cells(self, cells):
        """Owning rank of each coarse cell index along the slab axis."""
        ranks = np.searchsorted(self.bounds, cells, side="right") - 1
        return np.clip(ranks, 0, self.size - 1)

    def owned(self, rank):
        return int(self.bounds[rank]), int(self.bounds[rank + 1])

    def imbalance(self, cell_counts):
        """max/mean - 1 of the particle counts per rank given counts per cell."""
        per_rank = _per_rank_counts(cell_counts, self.bounds)
        mean = per_rank.mean()
        return float(per_rank.max() / mean - 1.0) if mean > 0 else 0.0

    def __eq__(self, other):
        return self.axis == other.axis and np.array_equal(self.bounds, other.bounds)

    def describe(self):
        return f"slabs along {AXES[self.axis]} at cells {self.bounds.tolist()}"


def _per_rank_counts(cell_counts, bounds):
    cumulative = np.concatenate([[0], np.cumsum(cell_counts)])
    return cumulative[bounds[1:]] - cumulative[bounds[:-1]]


def balanced_bounds(cell_counts, n_ranks, min_width=1):
    """Cut ``len(cell_counts)`` cells into ``n_ranks`` contiguous ranges of at least
    ``min_width`` cells whose particle counts are as equal as greedy cutting at the
    cumulative quantiles allows. The 27-node shape functions need slabs 3 cells wide: a
    particle reaches one node layer beyond its cell, so across a narrower slab a node
    would take points of both neighbours of its rank, and the sums over slab planes,
    neighbour by neighbour, would leave some rank without the other's share."""
    n_cells = len(cell_counts)
    if n_ranks * min_width > n_cells:
        raise ValueError(f"{n_ranks} ranks of at least {min_width} cells but only {n_cells} "
                         f"cells along the slab axis")
    cumulative = np.cumsum(cell_counts, dtype=np.float64)
    total = cumulative[-1] if n_cells else 0.0
    bounds = np.zeros(n_ranks + 1, dtype=np.int64)
    bounds[-1] = n_cells
    for r in range(1, n_ranks):
        target = total * r / n_ranks
        cut = int(np.searchsorted(cumulative, target, side="left")) + 1
        if cut > 1 and abs(cumulative[cut - 2] - target) <= abs(cumulative[cut - 1] - target):
            cut -= 1
        bounds[r] = min(max(cut, bounds[r - 1] + min_width),
                        n_cells - (n_ranks - r) * min_width)
    return bounds


def choose_slabs(cell_counts_per_axis, n_ranks, axis="auto", min_width=1,
                 like_two_ranks=False):
    """Pick the slab axis (given, or the one that balances best, ties to the smaller
    cut plane) and its balanced bounds, each slab at least ``min_width`` cells wide;
    with ``like_two_ranks``, ``auto`` is the axis two ranks would cut on any rank count
    whose slabs it admits (the layer-ordered sums run along it).
    ``cell_counts_per_axis`` holds three histograms. Raises SetupError, naming
    ``decomposition.axis``, when no candidate axis has enough cell layers for every
    rank."""
    candidates = range(3) if axis == "auto" else [AXES.index(axis)]
    layers = max(len(cell_counts_per_axis[a]) for a in candidates)
    if like_two_ranks and n_ranks != 2 and axis == "auto" and layers >= 2 * min_width:
        # the axis two ranks would cut, on every rank count that admits it: the
        # layer-ordered sums (pmpm.kernels.layered) run along the slab axis, so every rank
        # count then adds in the same order
        two = choose_slabs(cell_counts_per_axis, 2, axis, min_width).axis
        if len(cell_counts_per_axis[two]) >= n_ranks * min_width:
            axis, candidates = AXES[two], [two]
    if layers < n_ranks * min_width:
        raise SetupError([_too_many_ranks(axis, layers, n_ranks, min_width)])
    best = None
    for a in candidates:
        counts = cell_counts_per_axis[a]
        if len(counts) < n_ranks * min_width:
            continue
        slabs = Slabs(a, balanced_bounds(counts, n_ranks, min_width))
        plane = np.prod([len(cell_counts_per_axis[b]) for b in range(3) if b != a])
        key = (round(slabs.imbalance(counts), 3), plane)
        if best is None or key < best[0]:
            best = (key, slabs)
    return best[1]


def _too_many_ranks(axis, layers, n_ranks, min_width=1):
    """The problem line for ``n_ranks`` ranks when at most ``layers`` cell layers exist."""
    if axis == "auto":
        where, fix = "auto: no axis has more than", "use fewer ranks"
    else:
        where, fix = f"{axis} has", "choose another axis or fewer ranks"
    most = layers // min_width
    wide = "" if min_width == 1 else (f" (the 27-node shape functions need slabs "
                                      f"{min_width} cells wide)")
    return (f"decomposition.axis: {where} {_count(layers, 'cell layer')}: it can be split "
            f"among at most {_count(most, 'rank')}{wide} ({_count(n_ranks, 'rank')} asked); "
            f"{fix}")


def _count(n, noun):
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"
