"""Structure-of-arrays stores of material points: the generic column store, the
material-state column group, and the particle store."""
from .columns import MATERIAL_GROUP, ColumnStore, column_table
from .store import COLUMNS, Particles, PlainParticles, particle_store

__all__ = ["COLUMNS", "Particles", "PlainParticles", "ColumnStore", "MATERIAL_GROUP",
           "column_table", "particle_store"]
