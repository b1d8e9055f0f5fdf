"""Coarse grid geometry, refined windows, boundary codes and the per-rank node blocks."""
from .grid import FREE, SLIP, FIXED, BOUNDARY_CODES, CoarseGrid, LocalBlock
from .levels import Level, Window, window_bounds

__all__ = ["FREE", "SLIP", "FIXED", "BOUNDARY_CODES", "CoarseGrid", "LocalBlock", "Level",
           "Window", "window_bounds"]
