"""Boundary conditions on grid nodes: the codes of a box face and the constraint they
put on a nodal vector (velocity, acceleration, or a contact normal)."""
from numba import njit

FREE, SLIP, FIXED = 0, 1, 2
#: case-file name -> code; a symmetry plane is a slip face
BOUNDARY_CODES = {"free": FREE, "slip": SLIP, "fixed": FIXED, "symmetry": SLIP}


@njit(cache=True, inline="always")
def face_codes_of_node(n, block, out):
    """out[d] = code of the box face that the flat local node ``n`` of a ``NodeBlock``
    lies on along d (0 if none); ``block.boundary`` in the order x-, x+, y-, y+, z-, z+."""
    for d in range(3):
        g = block.lo[d] + (n // block.strides[d]) % block.shape[d]
        out[d] = 0
        if g == 0:
            out[d] = block.boundary[2 * d]
        elif g == block.n_cells[d]:
            out[d] = block.boundary[2 * d + 1]


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
