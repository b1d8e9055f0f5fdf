"""Fields derived from the state for every frame, named as ParaView users of explicit
codes expect: the pressure (compression positive, -tr(sigma)/3) and the von Mises
equivalent stress (sqrt(3/2 s:s), s the deviator), in the stress unit of the case."""
import numpy as np


def stress_invariants(stress):
    """(pressure, von_mises) of Voigt stresses ``stress`` (n, 6): xx, yy, zz, xy, yz, zx
    with tensor shear components (docs/CONTRACTS.md)."""
    return pressure_of(stress), von_mises_of(stress)


def pressure_of(stress):
    """-tr(sigma) / 3 of Voigt stresses (n, 6)."""
    stress = np.asarray(stress, dtype=np.float64)
    return -(stress[:, :3].sum(axis=1) / 3.0)


def von_mises_of(stress):
    """sqrt(3/2 s:s) of Voigt stresses (n, 6), s the deviator (tensor shear components)."""
    stress = np.asarray(stress, dtype=np.float64)
    mean = stress[:, :3].sum(axis=1) / 3.0
    dev = stress[:, :3] - mean[:, None]
    shear = stress[:, 3:]
    j2 = 0.5 * (dev ** 2).sum(axis=1) + (shear ** 2).sum(axis=1)
    return np.sqrt(3.0 * j2)


def with_stress_invariants(columns):
    """``columns`` with ``pressure`` and ``von_mises`` added from its ``stress``."""
    pressure, von_mises = stress_invariants(columns["stress"])
    return dict(columns, pressure=pressure, von_mises=von_mises)


class Deferred:
    """A frame column computed only when the writer reads it (``np.asarray``), so that a
    frame holds one derived or converted column at a time, not all of them at once (a
    particle frame made every column again, body-major, beside the state: the steel
    ball's peak memory was its frames', 217 bytes a particle above the step's).
    ``shape`` and ``dtype`` say what ``compute()`` returns."""

    def __init__(self, compute, shape, dtype):
        self.compute, self.shape, self.dtype = compute, tuple(shape), np.dtype(dtype)

    @property
    def ndim(self):
        return len(self.shape)

    def __len__(self):
        return self.shape[0]

    def __array__(self, dtype=None, copy=None):
        value = self.compute()
        return value if dtype is None else value.astype(dtype)


def deferred_frame_columns(columns, precision="float64"):
    """``columns`` (arrays, or :class:`Deferred`) with ``pressure`` and ``von_mises``
    added from ``stress`` and every float64 column cast to ``precision``, each computed
    when it is read."""
    stress, n = columns["stress"], len(columns["stress"])
    out = dict(columns,
               pressure=Deferred(lambda: pressure_of(stress), (n,), np.float64),
               von_mises=Deferred(lambda: von_mises_of(stress), (n,), np.float64))
    dtype = PRECISIONS[precision]
    if dtype is np.float64:
        return out
    return {name: Deferred(lambda v=value: np.asarray(v).astype(dtype), value.shape, dtype)
            if value.dtype == np.float64 else value for name, value in out.items()}


#: ``output.precision`` -> the numpy dtype of the frames' floating-point columns
PRECISIONS = {"float64": np.float64, "float32": np.float32}


def in_precision(columns, precision="float64"):
    """``columns`` with every float64 array cast to ``precision`` ("float32" halves the
    frames on disk; positions keep about 7 significant digits, plenty to look at a
    run, while the checkpoints stay float64 so that a restart is exact)."""
    dtype = PRECISIONS[precision]
    if dtype is np.float64:
        return columns
    return {name: value.astype(dtype) if getattr(value, "dtype", None) == np.float64
            else value for name, value in columns.items()}
