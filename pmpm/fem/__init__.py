"""Finite-element bodies (seed 004 Sec. 2.3): Numba kernels for explicit 8-node
hexahedra, free of MPI and configuration (DESIGN.md "Layers")."""
