"""Coarse grid geometry, refined windows, boundary codes and the per-rank node blocks."""
from ..kernels.boundary import BOUNDARY_CODES, FIXED, FREE, SLIP
from .grid import CoarseGrid, LocalBlock
from .levels import Level, Window, window_bounds

__all__ = ["FREE", "SLIP", "FIXED", "BOUNDARY_CODES", "CoarseGrid", "LocalBlock", "Level",
           "Window", "window_bounds"]
