"""Coarse grid geometry, boundary codes and the per-rank local node block."""
from .grid import FREE, SLIP, FIXED, BOUNDARY_CODES, CoarseGrid, LocalBlock

__all__ = ["FREE", "SLIP", "FIXED", "BOUNDARY_CODES", "CoarseGrid", "LocalBlock"]
