"""Geometry of the 8-node trilinear hexahedron (Numba, one element at a time).

Nodes are in VTK order: 0-3 the face zeta = -1 counter-clockwise seen from +zeta, 4-7 the
face zeta = +1 above them. With natural coordinates (xi, eta, zeta) the nodes sit at

    0 (-,-,-)  1 (+,-,-)  2 (+,+,-)  3 (-,+,-)  4 (-,-,+)  5 (+,-,+)  6 (+,+,+)  7 (-,+,+)

Flanagan and Belytschko (1981) mean gradient: ``b[I, i] = dV/dx_iI`` is the volume
integral of ``dN_I/dx_i`` over the element, exactly, for any trilinear hexahedron; the
uniform strain rate is then ``L = sum_I v_I (x) b_I / V`` and the internal force
``f_I = -sigma b_I``. The volume is ``V = sum_I x_I . b_I / 3`` (V is homogeneous of
degree 3 in the coordinates).

Each helper is inlined into its caller (``inline="always"``); arrays are passed in and
filled, so the element loop allocates nothing.
"""
import numpy as np
from numba import njit

#: Flanagan-Belytschko node permutations: row I lists the nodes that play the roles of
#: 0..7 in the formula for b of node I (the element seen from node I).
PERMUTATION = np.array([[0, 1, 2, 3, 4, 5, 6, 7],
                        [1, 2, 3, 0, 5, 6, 7, 4],
                        [2, 3, 0, 1, 6, 7, 4, 5],
                        [3, 0, 1, 2, 7, 4, 5, 6],
                        [4, 7, 6, 5, 0, 3, 2, 1],
                        [5, 4, 7, 6, 1, 0, 3, 2],
                        [6, 5, 4, 7, 2, 1, 0, 3],
                        [7, 6, 5, 4, 3, 2, 1, 0]], np.int64)

#: The four hourglass base vectors (eta zeta, xi zeta, xi eta, xi eta zeta at the nodes).
HOURGLASS = np.array([[1, 1, -1, -1, -1, -1, 1, 1],
                      [1, -1, -1, 1, -1, 1, 1, -1],
                      [1, -1, 1, -1, 1, -1, 1, -1],
                      [-1, 1, -1, 1, 1, -1, 1, -1]], np.float64)

#: The six faces, each counter-clockwise seen from outside.
FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4],
                  [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]], np.int64)


@njit(cache=True, inline="always")
def _b_component(xe, cy, cz, p):
    """One component of dV/dx at the node whose permutation is ``p``, from the other two
    coordinates, columns ``cy`` and ``cz`` of ``xe`` (cyclic order x -> y -> z -> x).
    Indexed in ``xe`` itself: passing the columns as slices cost twice the time."""
    y1, y2, y3, y4 = xe[p[1], cy], xe[p[2], cy], xe[p[3], cy], xe[p[4], cy]
    y5, y7 = xe[p[5], cy], xe[p[7], cy]
    z1, z2, z3, z4 = xe[p[1], cz], xe[p[2], cz], xe[p[3], cz], xe[p[4], cz]
    z5, z7 = xe[p[5], cz], xe[p[7], cz]
    return (y1 * ((z5 - z2) - (z3 - z4)) + y2 * (z1 - z3)
            + y3 * ((z2 - z7) - (z4 - z1)) + y4 * ((z7 - z5) - (z1 - z3))
            + y5 * (z4 - z1) + y7 * (z3 - z4)) / 12.0


@njit(cache=True, inline="always")
def mean_gradient(xe, b):
    """Fill ``b`` (8, 3) with dV/dx_I of the element with node coordinates ``xe`` (8, 3);
    returns the volume V."""
    volume = 0.0
    for node in range(8):
        p = PERMUTATION[node]
        b[node, 0] = _b_component(xe, 1, 2, p)
        b[node, 1] = _b_component(xe, 2, 0, p)
        b[node, 2] = _b_component(xe, 0, 1, p)
        volume += xe[node, 0] * b[node, 0] + xe[node, 1] * b[node, 1] \
            + xe[node, 2] * b[node, 2]
    return volume / 3.0


@njit(cache=True)
def boundary_volumes(x, hexes, volumes):
    """Fill ``volumes`` (m,) with each element's volume as the flux of x / 3 through its
    six faces (the divergence theorem; a bilinear face's area vector is half the cross
    product of its diagonals, and the flux of x through it is its corners' mean dotted
    with that): exact for the trilinear hexahedron, so :func:`element_volumes`' volume to
    round-off (3e-16 of it on randomly distorted elements), at a third of its cost (17
    against 51 ns an element). For the conversion check of every step
    (pmpm.solver.conversion); the set-up keeps :func:`element_volumes`, whose bits the
    element masses carry."""
    for e in range(hexes.shape[0]):
        flux = 0.0
        for f in range(6):
            a, b = hexes[e, FACES[f, 0]], hexes[e, FACES[f, 1]]
            c, d = hexes[e, FACES[f, 2]], hexes[e, FACES[f, 3]]
            p0, p1, p2 = x[c, 0] - x[a, 0], x[c, 1] - x[a, 1], x[c, 2] - x[a, 2]
            q0, q1, q2 = x[d, 0] - x[b, 0], x[d, 1] - x[b, 1], x[d, 2] - x[b, 2]
            flux += ((x[a, 0] + x[b, 0] + x[c, 0] + x[d, 0]) * (p1 * q2 - p2 * q1)
                     + (x[a, 1] + x[b, 1] + x[c, 1] + x[d, 1]) * (p2 * q0 - p0 * q2)
                     + (x[a, 2] + x[b, 2] + x[c, 2] + x[d, 2]) * (p0 * q1 - p1 * q0))
        volumes[e] = flux / 24.0


@njit(cache=True, inline="always")
def largest_face_area(xe):
    """The largest of the six face areas, each half the norm of its diagonals' cross
    product (exact for a plane face). One square root, of the largest squared norm: the
    root is monotone and correctly rounded, so this is the largest of the six roots to
    the bit."""
    largest = 0.0
    for f in range(6):
        a, b, c, d = FACES[f, 0], FACES[f, 1], FACES[f, 2], FACES[f, 3]
        p0, p1, p2 = xe[c, 0] - xe[a, 0], xe[c, 1] - xe[a, 1], xe[c, 2] - xe[a, 2]
        q0, q1, q2 = xe[d, 0] - xe[b, 0], xe[d, 1] - xe[b, 1], xe[d, 2] - xe[b, 2]
        n0, n1, n2 = p1 * q2 - p2 * q1, p2 * q0 - p0 * q2, p0 * q1 - p1 * q0
        largest = max(largest, n0 * n0 + n1 * n1 + n2 * n2)
    return 0.5 * np.sqrt(largest)


@njit(cache=True, inline="always")
def hourglass_shapes(xe, b, inv_volume, gamma):
    """Fill ``gamma`` (4, 8) with the Flanagan-Belytschko hourglass shape vectors
    gamma_a = h_a - (h_a . x_i) b_i / V (``inv_volume`` = 1 / V): orthogonal to every linear velocity field, so
    they pick out the hourglass modes only."""
    for a in range(4):
        hx = hy = hz = 0.0
        for node in range(8):
            h = HOURGLASS[a, node]
            hx += h * xe[node, 0]
            hy += h * xe[node, 1]
            hz += h * xe[node, 2]
        for node in range(8):
            gamma[a, node] = HOURGLASS[a, node] - (hx * b[node, 0] + hy * b[node, 1]
                                                   + hz * b[node, 2]) * inv_volume


@njit(cache=True)
def element_geometry(xe, b):
    """(volume, largest face area) of one element, ``b`` filled as in mean_gradient
    (a separately compiled entry point, for set-up and tests)."""
    return mean_gradient(xe, b), largest_face_area(xe)


@njit(cache=True)
def element_volumes(x, hexes, volumes):
    """Fill ``volumes`` (m,) with the volume of each element of ``hexes`` (m, 8) over the
    node coordinates ``x`` (n, 3) (negative for an inverted element)."""
    xe, b = np.empty((8, 3)), np.empty((8, 3))
    for e in range(hexes.shape[0]):
        for k in range(8):
            for i in range(3):
                xe[k, i] = x[hexes[e, k], i]
        volumes[e] = mean_gradient(xe, b)
