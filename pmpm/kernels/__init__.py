"""Numba kernels of one explicit MPM step. No MPI, no configuration, no allocation per
particle: every function takes arrays and fills arrays, and runs serially on small input."""
