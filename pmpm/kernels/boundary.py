"""Boundary conditions on grid nodes: the codes of a box face and the constraint they
put on a nodal vector (velocity, acceleration, or a contact normal).

A node's conditions are packed in one byte, two bits per axis (``code >> 2 d & 3`` is
the code of the box face the node lies on along axis d, 0 if none), in a table made once
per block (:func:`fill_face_codes`), so the node loops test one byte per node."""
import numpy as np
from numba import njit

FREE, SLIP, FIXED = 0, 1, 2
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
                    elif g[d] >= n_cells[d]:
                        code |= bc[2 * d + 1] << (2 * d)
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
