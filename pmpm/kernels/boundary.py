"""Boundary conditions on grid nodes: the codes of a box face and the constraint they
put on a nodal vector (velocity, acceleration, or a contact normal)."""
from numba import njit

FREE, SLIP, FIXED = 0, 1, 2
#: case-file name -> code; a symmetry plane is a slip face
BOUNDARY_CODES = {"free": FREE, "slip": SLIP, "fixed": FIXED, "symmetry": SLIP}


@njit(cache=True, inline="always")
def face_codes(i, j, k, lo, n_cells, bc, out):
    """out[d] = code of the box face that local node (i, j, k) of a block starting at
    global node ``lo`` lies on along d (0 if none); ``bc`` in the order x-, x+, y-, y+,
    z-, z+."""
    g = (lo[0] + i, lo[1] + j, lo[2] + k)
    for d in range(3):
        out[d] = 0
        if g[d] == 0:
            out[d] = bc[2 * d]
        elif g[d] == n_cells[d]:
            out[d] = bc[2 * d + 1]


@njit(cache=True, inline="always")
def face_codes_of_node(n, block, out):
    """:func:`face_codes` of the flat local node ``n`` of a ``NodeBlock``."""
    face_codes((n // block.strides[0]) % block.shape[0],
               (n // block.strides[1]) % block.shape[1],
               (n // block.strides[2]) % block.shape[2],
               block.lo, block.n_cells, block.boundary, out)


@njit(cache=True, inline="always")
def constrain(vec, mask):
    """A fixed face zeroes the whole vector; a slip face its component along the face's
    normal (``mask``: the node's face codes)."""
    for d in range(3):
        if mask[d] == FIXED:
            vec[0] = vec[1] = vec[2] = 0.0
            return
    for d in range(3):
        if mask[d] == SLIP:
            vec[d] = 0.0
