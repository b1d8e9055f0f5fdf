"""The particle store: a :class:`~pmpm.particles.columns.ColumnStore` with the particle
columns, one contiguous array per column, first axis the particle.

Every column travels with a particle when it migrates, is written to checkpoints and is
permuted together when particles are re-sorted by cell.
"""
import numpy as np

from pmpm.materials.state import with_later_columns

from .columns import MATERIAL_GROUP, ColumnStore, column_table

F8, I8, I4 = np.float64, np.int64, np.int32

#: name -> (dtype, components per particle), in checkpoint and output order; the bare
#: names are the material group's columns, and the group's columns not named here
#: (damage, w_p) follow at the end; see docs/CONTRACTS.md
COLUMNS = column_table(
    [("x", F8, 3), ("v", F8, 3), ("mass", F8, 1), "rho", ("vol0", F8, 1), "stress", "F",
     "eps_p", "e_int", "temp", "q", ("load_scale", F8, 1), ("id", I8, 1),
     ("body", I4, 1), ("load", I4, 1), ("refine", I4, 1), ("affine", F8, 9),
     ("x0", F8, 3)],
    groups=[MATERIAL_GROUP])

IDENTITY9 = np.eye(3).reshape(9)
#: the columns of a run without APIC: every column but the affine matrices, 72 bytes a
#: particle that only ``time.transfer: apic`` reads
PLAIN_COLUMNS = {name: spec for name, spec in COLUMNS.items() if name != "affine"}


class Particles(ColumnStore):
    """The particles a rank owns.

    Attributes are the columns of :data:`COLUMNS` (``particles.x``, ``particles.stress``...).
    """

    COLUMNS = COLUMNS

    def __init__(self, columns):
        if "refine" not in columns and "mass" in columns:    # checkpoints before windows
            columns = dict(columns, refine=np.ones(len(columns["mass"]), np.int32))
        if "affine" in self.COLUMNS and "affine" not in columns and "mass" in columns:
            # checkpoints before APIC, or of a run without it
            columns = dict(columns, affine=np.zeros((len(columns["mass"]), 9)))
        if "x0" not in columns and "x" in columns:   # checkpoints before displacements
            columns = dict(columns, x0=np.array(columns["x"], np.float64))
        if "mass" in columns:                                # checkpoints before damage
            columns = with_later_columns(columns, len(columns["mass"]))
        super().__init__(columns)

    @classmethod
    def bytes_per_particle(cls):
        return cls.bytes_per_row()


class PlainParticles(Particles):
    """The particles of a run without APIC: no ``affine`` column."""

    COLUMNS = PLAIN_COLUMNS


def particle_store(apic):
    """The store class of a run: :class:`Particles` with APIC, else
    :class:`PlainParticles`."""
    return Particles if apic else PlainParticles


empty_column = Particles.empty_column
