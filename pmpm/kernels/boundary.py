"""Boundary conditions on grid nodes: the codes of a box face and the constraint they
put on a nodal vector (velocity, acceleration, or a contact normal).

A node's conditions are packed in 16 bits, two bits per axis (``code >> 2 d & 3`` is
the code of the box face the node lies on along axis d, 0 if none) and, in bit
``UPPER + d``, whether that face is the upper one (x+, y+, z+), in a table made once per
block (:func:`fill_face_codes`), so the node loops test one number per node.

A slip face with a Coulomb coefficient (``grid.friction``) is a *wall*: material may
leave it, and where it presses on it its tangential velocity changes by at most mu
times the normal change (:func:`constrain_velocity`, :func:`constrain_acceleration`;
the rule of grid contact, seed 001 Eqs. 12-22, against a body at rest). A slip face
without friction keeps the normal velocity zero both ways (a symmetry plane)."""
import numpy as np
from numba import njit

FREE, SLIP, FIXED = 0, 1, 2
#: the bit of the packed code that marks axis 0's face as the upper one (axis d: UPPER + d)
UPPER = 6
#: case-file name -> code; a symmetry plane is a slip face
BOUNDARY_CODES = {"free": FREE, "slip": SLIP, "fixed": FIXED, "symmetry": SLIP}


@njit(cache=True, inline="always")
def mirrors(code, friction_face):
    """Whether a box face of ``code`` (and Coulomb coefficient ``friction_face``) is a
    plane of symmetry for the nodes beyond it: a slip face without friction (its image is
    the body reflected across it) or a fixed face (its image is the body reflected and
    moving the opposite way, so that the face stays at rest)."""
    return (code == SLIP and friction_face == 0.0) or code == FIXED


@njit(cache=True)
def fill_face_codes(shape, lo, strides, n_cells, bc, friction, faces):
    """faces[n] = the packed face codes of every local node n of a block (``shape``,
    ``lo``, ``strides``) of a level with ``n_cells`` cells, the box-face codes ``bc`` and
    Coulomb coefficients ``friction`` in the order x-, x+, y-, y+, z-, z+. A node beyond
    a face (the halo of the 27-node shape functions, ``pmpm.kernels.shape``) takes that
    face's condition, like the node on it, unless the face :func:`mirrors`: such a node
    is the reflection of its image inside the box (:func:`mirror_rows`) and takes the
    condition of the image instead (none, unless a box one cell thick puts the image on
    the opposite face)."""
    g = np.empty(3, np.int64)
    for i in range(shape[0]):
        for j in range(shape[1]):
            for k in range(shape[2]):
                g[0], g[1], g[2] = lo[0] + i, lo[1] + j, lo[2] + k
                code = 0
                for d in range(3):
                    lower, upper = bc[2 * d], bc[2 * d + 1]
                    if g[d] < 0 and mirrors(lower, friction[2 * d]):
                        g[d] = -g[d]                            # the image's condition
                    elif g[d] > n_cells[d] and mirrors(upper, friction[2 * d + 1]):
                        g[d] = 2 * n_cells[d] - g[d]
                    if g[d] <= 0:
                        code |= lower << (2 * d)
                    elif g[d] >= n_cells[d] and upper != FREE:
                        code |= (upper << (2 * d)) | (1 << (UPPER + d))
                faces[i * strides[0] + j * strides[1] + k * strides[2]] = code


@njit(cache=True, inline="always")
def constrain_coded(vec, code):
    """A fixed face zeroes the whole vector; a slip face its component along the face's
    normal (``code``: the node's packed face codes)."""
    for d in range(3):
        if (code >> (2 * d)) & 3 == FIXED:
            vec[0] = vec[1] = vec[2] = 0.0
            return
    for d in range(3):
        if (code >> (2 * d)) & 3 == SLIP:
            vec[d] = 0.0


@njit(cache=True, inline="always")
def _is_wall(code, d, friction):
    """(whether axis d's face of the node is a slip face with friction, 1 if it is the
    upper face else 0)."""
    upper = (code >> (UPPER + d)) & 1
    return (code >> (2 * d)) & 3 == SLIP and friction[2 * d + upper] > 0.0, upper


@njit(cache=True, inline="always")
def _into(value, upper):
    """The component ``value`` along the normal into the face (outward of the box)."""
    return value if upper else -value


@njit(cache=True, inline="always")
def constrain_velocity(vec, code, friction):
    """:func:`constrain_coded` for a nodal velocity, except on walls (slip faces with
    friction), which stop only motion into them."""
    kept = np.int64(code)
    for d in range(3):
        wall, upper = _is_wall(kept, d, friction)
        if wall and _into(vec[d], upper) < 0.0:
            kept &= ~np.int64(3 << (2 * d))   # leaving the wall: no constraint on axis d
    constrain_coded(vec, kept)


@njit(cache=True, inline="always")
def constrain_acceleration(acc, vel, code, friction, dt):
    """:func:`constrain_coded` for a nodal acceleration ``acc`` over a step ``dt`` from
    the start velocity ``vel``; on walls: where the velocity at the end of the step,
    ``vel + acc dt``, moves into the wall, its normal part is removed and the tangential
    velocity changes by at most mu times the normal change, never reversing (Coulomb:
    sliding decelerates, sticking stops); where it leaves the wall, nothing."""
    code = np.int64(code)
    for d in range(3):
        if (code >> (2 * d)) & 3 == FIXED:
            acc[0] = acc[1] = acc[2] = 0.0
            return
    for d in range(3):
        wall, upper = _is_wall(code, d, friction)
        if wall:
            into = _into(vel[d] + acc[d] * dt, upper)
            if into > 0.0:
                acc[d] = -vel[d] / dt
                _limit_tangential(acc, vel, d, friction[2 * d + upper] * into, dt)
        elif (code >> (2 * d)) & 3 == SLIP:
            acc[d] = 0.0


@njit(cache=True, inline="always")
def _limit_tangential(acc, vel, normal_axis, largest_change, dt):
    """Reduce the tangential (to axis ``normal_axis``) velocity at the end of the step,
    ``vel + acc dt``, by at most ``largest_change`` along itself, and to zero at most."""
    speed2 = 0.0
    for d in range(3):
        if d != normal_axis:
            speed2 += (vel[d] + acc[d] * dt) ** 2
    speed = speed2 ** 0.5
    keep = 0.0 if speed <= largest_change else 1.0 - largest_change / speed
    for d in range(3):
        if d != normal_axis:
            acc[d] = ((vel[d] + acc[d] * dt) * keep - vel[d]) / dt


#: what a column of a mirrored nodal array holds (:func:`mirror_rows`): a scalar, a
#: component of a velocity-like vector along axis e (``VELOCITY + e``: odd across a fixed
#: face, its normal component odd across a slip face), or of a geometric vector along
#: axis e (``GEOMETRIC + e``: a mass gradient or an offset, its normal component odd)
SCALAR, VELOCITY, GEOMETRIC = 0, 1, 4


def column_kinds(width, velocity=(), geometric=()):
    """The :func:`mirror_rows` column kinds of an array of ``width`` columns whose
    velocity-like 3-vectors start at the columns ``velocity`` and geometric ones at
    ``geometric``."""
    kinds = np.full(width, SCALAR, np.int64)
    for first, kind in [(c, VELOCITY) for c in velocity] + [(c, GEOMETRIC) for c in geometric]:
        kinds[first:first + 3] = kind + np.arange(3)
    return kinds


@njit(cache=True)
def mirror_pairs(block):
    """The (node beyond a face, its image inside the box, face) triples of a local block
    (a NodeBlock) for the box faces that :func:`mirrors` (face: 2 d + upper), grouped by
    face in the order x-, x+, y-, y+, z-, z+. Only the 27-node shapes reach such nodes
    (their halo); a block without any gives none."""
    shape, lo, strides, n_cells = block.shape, block.lo, block.strides, block.n_cells
    count = 0
    for sweep in range(2):
        if sweep:
            pairs = np.empty((count, 3), np.int64)
            count = 0
        for f in range(6):
            d, upper = f // 2, f % 2
            if not mirrors(block.boundary[f], block.friction[f]):
                continue
            face = n_cells[d] if upper else 0
            a, b = (d + 1) % 3, (d + 2) % 3
            for i in range(shape[d]):
                g = lo[d] + i
                beyond = g > face if upper else g < face
                j = 2 * face - g - lo[d]
                if not beyond or j < 0 or j >= shape[d]:
                    continue
                for ia in range(shape[a]):
                    for ib in range(shape[b]):
                        if sweep:
                            rest = ia * strides[a] + ib * strides[b]
                            pairs[count, 0] = i * strides[d] + rest
                            pairs[count, 1] = j * strides[d] + rest
                            pairs[count, 2] = f
                        count += 1
    return pairs


@njit(cache=True)
def mirror_rows(arr, kinds, pairs, bc, slot_of, tied):
    """Reflect the nodal rows ``arr`` (rows, n_bodies, c) across the box faces of
    ``pairs`` (:func:`mirror_pairs`; ``bc`` the box-face codes), one face after the
    other: each node beyond a face is first folded into its image inside the box (its
    values added to the image's, reflected by the column ``kinds``), then takes the
    image's values reflected. Row r of a node n is ``slot_of[n]`` (nodes without a row
    skipped), or n itself when ``slot_of`` is None. A pair with a tied slave
    (``tied[n]`` nonzero; ``tied`` None: none) is left alone: a slave takes its values
    from its masters, and its own were given to them before.

    This is what particles mirrored across the face would put on the grid: the velocity
    is even in its tangential components and odd in the normal one across a slip face
    (odd in all three across a fixed face), so that a particle near the face sees the
    strain rate the hats give it, instead of about half of it with the halo nodes merely
    constrained (what narrowed a Taylor bar's foot 12 % with the 27-node shapes)."""
    sign = np.empty(arr.shape[2])
    start = 0
    while start < pairs.shape[0]:
        f = pairs[start, 2]
        stop = start
        while stop < pairs.shape[0] and pairs[stop, 2] == f:
            stop += 1
        _column_signs(kinds, f // 2, bc[f], sign)
        for fold in (True, False):
            for k in range(start, stop):
                n, m = pairs[k, 0], pairs[k, 1]
                if tied is not None:
                    if tied[n] or tied[m]:
                        continue
                if slot_of is not None:
                    n, m = slot_of[n], slot_of[m]
                    if n < 0 or m < 0:
                        continue
                for b in range(arr.shape[1]):
                    for c in range(arr.shape[2]):
                        if fold:
                            arr[m, b, c] += sign[c] * arr[n, b, c]
                        else:
                            arr[n, b, c] = sign[c] * arr[m, b, c]
        start = stop


@njit(cache=True, inline="always")
def _column_signs(kinds, d, code, sign):
    for c in range(kinds.shape[0]):
        k = kinds[c]
        sign[c] = 1.0
        if k >= GEOMETRIC:
            if k - GEOMETRIC == d:
                sign[c] = -1.0
        elif k >= VELOCITY:
            if k - VELOCITY == d or code == FIXED:
                sign[c] = -1.0


@njit(cache=True)
def mirror_masks(mask, pairs):
    """The body masks of contact detection reflected like :func:`mirror_rows`: a node
    and its image across a mirrored face are reached by the same bodies."""
    start = 0
    while start < pairs.shape[0]:
        stop = start
        while stop < pairs.shape[0] and pairs[stop, 2] == pairs[start, 2]:
            stop += 1
        for k in range(start, stop):
            mask[pairs[k, 1]] |= mask[pairs[k, 0]]
        for k in range(start, stop):
            mask[pairs[k, 0]] = mask[pairs[k, 1]]
        start = stop


@njit(cache=True)
def mirror_extents(cext, pairs, slot_of):
    """The release rule's farthest reaches (``pmpm.kernels.contact.contact_extents``,
    (slots, n_bodies, 6): +x, +y, +z, -x, -y, -z) reflected like :func:`mirror_rows`:
    across a face normal to d the reach along +d of the image is the reach along -d of
    the original; folding takes the larger."""
    start = 0
    while start < pairs.shape[0]:
        d = pairs[start, 2] // 2
        stop = start
        while stop < pairs.shape[0] and pairs[stop, 2] == pairs[start, 2]:
            stop += 1
        for fold in (True, False):
            for k in range(start, stop):
                n, m = slot_of[pairs[k, 0]], slot_of[pairs[k, 1]]
                if n < 0 or m < 0:
                    continue
                for b in range(cext.shape[1]):
                    for c in range(6):
                        e = c if c % 3 != d else (c + 3) % 6
                        if fold:
                            cext[m, b, c] = max(cext[m, b, c], cext[n, b, e])
                        else:
                            cext[n, b, c] = cext[m, b, e]
        start = stop
