"""The particle store: one contiguous array per column, first axis the particle.

Every column travels with a particle when it migrates, is written to checkpoints and is
permuted together when particles are re-sorted by cell.
"""
import numpy as np

#: name -> (dtype, components per particle); see docs/CONTRACTS.md
COLUMNS = {
    "x": (np.float64, 3),
    "v": (np.float64, 3),
    "mass": (np.float64, 1),
    "rho": (np.float64, 1),
    "vol0": (np.float64, 1),
    "stress": (np.float64, 6),
    "F": (np.float64, 9),
    "eps_p": (np.float64, 1),
    "e_int": (np.float64, 1),
    "temp": (np.float64, 1),
    "q": (np.float64, 1),
    "load_scale": (np.float64, 1),
    "id": (np.int64, 1),
    "body": (np.int32, 1),
    "load": (np.int32, 1),
    "refine": (np.int32, 1),
}

IDENTITY9 = np.eye(3).reshape(9)


def empty_column(name, n):
    dtype, width = COLUMNS[name]
    return np.zeros((n, width) if width > 1 else n, dtype=dtype)


class Particles:
    """The particles a rank owns.

    Attributes are the columns of :data:`COLUMNS` (``particles.x``, ``particles.stress``...).
    """

    def __init__(self, columns):
        if "refine" not in columns and "mass" in columns:    # checkpoints before windows
            columns = dict(columns, refine=np.ones(len(columns["mass"]), np.int32))
        missing = set(COLUMNS) - set(columns)
        if missing:
            raise ValueError(f"particle columns missing: {sorted(missing)}")
        self.set_columns(columns)

    @classmethod
    def empty(cls, n=0):
        return cls({name: empty_column(name, n) for name in COLUMNS})

    def set_columns(self, columns):
        for name in COLUMNS:
            dtype, _ = COLUMNS[name]
            setattr(self, name, np.ascontiguousarray(columns[name], dtype=dtype))

    @property
    def n(self):
        return len(self.mass)

    def columns(self):
        return {name: getattr(self, name) for name in COLUMNS}

    def take(self, index):
        """Keep only the particles ``index`` (bool mask or integer array), in that order.
        One column at a time, so the extra memory is one column, not the whole store."""
        for name in COLUMNS:
            setattr(self, name, np.ascontiguousarray(getattr(self, name)[index]))

    def replace_column(self, name, values):
        dtype, _ = COLUMNS[name]
        setattr(self, name, np.ascontiguousarray(values, dtype=dtype))

    def append(self, other_columns):
        """Add particles at the end, one column at a time (the extra memory is one
        column, not the whole store)."""
        for name in COLUMNS:
            dtype, _ = COLUMNS[name]
            joined = np.concatenate([getattr(self, name), other_columns[name]]).astype(
                dtype, copy=False)
            setattr(self, name, joined)

    def nbytes(self):
        return sum(col.nbytes for col in self.columns().values())

    @staticmethod
    def bytes_per_particle():
        return sum(np.dtype(dtype).itemsize * width for dtype, width in COLUMNS.values())
