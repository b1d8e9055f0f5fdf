"""Structure-of-arrays stores of material points: the generic column store, the
material-state column group, and the particle store."""
from .columns import MATERIAL_GROUP, ColumnStore, column_table
from .store import COLUMNS, Particles

__all__ = ["COLUMNS", "Particles", "ColumnStore", "MATERIAL_GROUP", "column_table"]
