"""Layer-ordered scatter sums: nodal sums whose bits do not depend on the rank count.

A node's value is the sum over the particles' cell layers along the slab axis, in
increasing layer order, of that layer's sum, and a layer's sum adds its particles in a
canonical order (the order array: cell with the slab axis slowest, then id). Slabs cut
between cell layers, so a layer's sum is the same on any rank count, and the fold over
layers is the same too once the shared planes are combined layer by layer
(``pmpm.comm.exchange.sum_shared_planes_in_layer_order``): the lower rank's fold is the
one-rank fold's prefix, and the upper rank keeps its first layers' sums apart so that
both continue that prefix in the same order.

A scatter kernel adds a particle's contributions into ``scratch``, a window of
``2 + 2 halo`` node planes starting at the lower halo plane of the particle's layer
(flat node index minus ``shift``), and :func:`flush_layer` adds the window into the
nodal array when the layer changes. The cost: ``2 + 2 halo`` adds per node per step,
against about 200 particle updates per node.

The ``LayerSums`` record (``pmpm.kernels.records``): ``order`` (n,) the particles in
canonical order, ``axis`` the slab axis, ``plane`` nodes per node plane, ``n_planes``
planes in the block, ``halo`` node layers a shape reaches beyond the cell, ``scratch``
((2 + 2 halo) * plane, width) zeros, ``kept`` (2 halo + 1, (2 halo + 1) * plane, width)
zeros: the sums of the rank's first ``2 halo + 1`` layers on the planes it shares with
the rank below (empty when it has none).
"""
import numpy as np
from numba import njit

#: the layer before any particle: no window to flush yet
NO_LAYER = -(2 ** 62)


@njit(cache=True, inline="always")
def layer_plane(x, p, origin, inv_h, lo, axis):
    """The local node plane of the lower face of particle p's cell along the slab axis
    (the same floor the slab classification takes)."""
    return np.int64(np.floor((x[p, axis] - origin[axis]) * inv_h)) - lo[axis]


@njit(cache=True)
def flush_layer(target, layers, scratch, layer):
    """Add the window of ``layer`` (a local cell plane) into ``target``, keep the sums
    on the lower shared planes of the rank's first layers, and zero the window."""
    plane, halo, kept = layers.plane, layers.halo, layers.kept
    first = layer - halo
    n_kept = kept.shape[0]
    width = target.shape[1]
    for j in range(2 + 2 * halo):
        P = first + j
        if P < 0 or P >= layers.n_planes:
            continue
        src, dst = j * plane, P * plane
        for i in range(plane):
            for c in range(width):
                target[dst + i, c] += scratch[src + i, c]
        if 0 <= first < n_kept and P < n_kept:
            for i in range(plane):
                for c in range(width):
                    kept[first, dst + i, c] = scratch[src + i, c]
    scratch[:, :] = 0.0
