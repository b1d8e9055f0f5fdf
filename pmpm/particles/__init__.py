"""Structure-of-arrays particle store."""
from .store import COLUMNS, Particles

__all__ = ["COLUMNS", "Particles"]
