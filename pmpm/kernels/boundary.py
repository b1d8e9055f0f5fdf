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


@njit(cache=True)
def fill_face_codes(shape, lo, strides, n_cells, bc, faces):
    """faces[n] = the packed face codes of every local node n of a block (``shape``,
    ``lo``, ``strides``) of a level with ``n_cells`` cells and the box-face codes ``bc``
    in the order x-, x+, y-, y+, z-, z+. A node beyond a face (the halo of the 27-node
    shape functions, ``pmpm.kernels.shape``) takes that face's condition, like the node
    on it."""
    g = np.empty(3, np.int64)
    for i in range(shape[0]):
        for j in range(shape[1]):
            for k in range(shape[2]):
                g[0], g[1], g[2] = lo[0] + i, lo[1] + j, lo[2] + k
                code = 0
                for d in range(3):
                    if g[d] <= 0:
                        code |= bc[2 * d] << (2 * d)
                    elif g[d] >= n_cells[d] and bc[2 * d + 1] != FREE:
                        code |= (bc[2 * d + 1] << (2 * d)) | (1 << (UPPER + d))
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
