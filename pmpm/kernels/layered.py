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
(row minus ``starts[layer - halo]``), and :func:`flush_layer` adds the window into the
array when the layer changes. The cost: ``2 + 2 halo`` adds per node per step, against
about 200 particle updates per node. Rows are nodes (the nodal arrays) or contact slots
(numbered in node order, so a plane's slots are one run of rows too).

The ``LayerSums`` record (``pmpm.kernels.records``): ``order`` (n,) the particles in
canonical order, ``axis`` the slab axis, ``starts`` (n_planes + 1,) the first row of
each node plane of the block, ``halo`` node layers a shape reaches beyond the cell,
``scratch`` (rows of the widest window, width) zeros, ``kept`` (2 halo + 1, rows of the
first 2 halo + 1 planes, width) zeros: the sums of the rank's first ``2 halo + 1``
layers on the planes it shares with the rank below (no layer when it has none).

A scatter kernel's particle loop, with or without a record::

    order, count, axis, starts, halo, scratch, kept = unpack(layers, n)
    for i in range(count):
        p = point_at(layers, order, i)
        ...
        if layers is not None:
            layer = layer_plane(x, p, origin, inv_h, lo, axis)
            if layer != current:    # here, not in leave_layer: 2.5 times faster
                leave_layer(layer, current, target, scratch, starts, halo, kept)
                current, shift = layer, starts[layer - halo]
        ...             # add into scratch at row - shift
    if layers is not None:
        leave_layer(NO_LAYER, current, target, scratch, starts, halo, kept)
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
def unpack(layers, n):
    """The record's arrays for a particle loop, (order, count, axis, starts, halo,
    scratch, kept), or without a record (None) the loop over the ``n`` particles in
    array order (empty arrays). Unpacked once per kernel call: a record used inside the
    loop costs a reference count per particle."""
    if layers is None:
        return (np.empty(0, np.int64), n, 0, np.empty(0, np.int64), 0, np.empty((0, 0)),
                np.empty((0, 0, 0)))
    return (layers.order, layers.order.shape[0], layers.axis, layers.starts, layers.halo,
            layers.scratch, layers.kept)


@njit(cache=True, inline="always")
def point_at(layers, order, i):
    """The loop's i-th particle: the i-th of the canonical ``order`` with a record, else
    the i-th of the arrays."""
    if layers is None:
        return i
    return order[i]


@njit(cache=True, inline="always")
def leave_layer(layer, current, target, scratch, starts, halo, kept):
    """Flush the window of the ``current`` layer into ``target`` when the loop's next
    particle is of another ``layer`` (:data:`NO_LAYER` after the last particle)."""
    if layer != current and current != NO_LAYER:
        flush_layer(target, scratch, starts, halo, kept, current)


@njit(cache=True)
def flush_layer(target, scratch, starts, halo, kept, layer):
    """Add the window of ``layer`` (a local cell plane) into ``target`` (rows, c), keep
    its rows on the planes the rank shares with the rank below if it is one of the
    rank's first layers, and zero the window. Takes the record's arrays, not the record:
    a record used inside a particle loop costs a reference count per particle."""
    first = layer - halo
    last = min(first + 2 + 2 * halo, starts.shape[0] - 1)
    shift, rows = starts[first], starts[last] - starts[first]
    width = target.shape[1]
    for i in range(rows):
        for c in range(width):
            target[shift + i, c] += scratch[i, c]
    if first < kept.shape[0]:
        for i in range(min(rows, kept.shape[1] - shift)):
            for c in range(width):
                kept[first, shift + i, c] = scratch[i, c]
    scratch[:rows, :] = 0.0
