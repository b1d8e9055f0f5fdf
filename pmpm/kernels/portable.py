"""Elementwise functions whose last bits do not depend on the CPU.

NumPy dispatches some ufuncs, ``np.cbrt`` among them, to SIMD implementations it picks
by the CPU at run time: on a CPU with AVX-512 its cube root can differ in the last bit
from the C library's that it calls elsewhere, so an answer that goes through it moved
with the machine (the refined Taylor bar's children are placed by their parent's spacing;
its golden answer held on one machine and not on another). These loops call the C
library's scalar function on every element, whatever SIMD the CPU has. Kernels
compiled by Numba call the C library's functions already."""
import numpy as np
from numba import njit


@njit(cache=True)
def cube_roots(values):
    """The cube root of each element of the 1D float64 array ``values``."""
    out = np.empty(values.shape[0])
    for i in range(values.shape[0]):
        out[i] = np.cbrt(values[i])
    return out
