"""Fields derived from the state for every frame, named as ParaView users of explicit
codes expect: the pressure (compression positive, -tr(sigma)/3) and the von Mises
equivalent stress (sqrt(3/2 s:s), s the deviator), in the stress unit of the case."""
import numpy as np


def stress_invariants(stress):
    """(pressure, von_mises) of Voigt stresses ``stress`` (n, 6): xx, yy, zz, xy, yz, zx
    with tensor shear components (docs/CONTRACTS.md)."""
    stress = np.asarray(stress, dtype=np.float64)
    mean = stress[:, :3].sum(axis=1) / 3.0
    dev = stress[:, :3] - mean[:, None]
    shear = stress[:, 3:]
    j2 = 0.5 * (dev ** 2).sum(axis=1) + (shear ** 2).sum(axis=1)
    return -mean, np.sqrt(3.0 * j2)


def with_stress_invariants(columns):
    """``columns`` with ``pressure`` and ``von_mises`` added from its ``stress``."""
    pressure, von_mises = stress_invariants(columns["stress"])
    return dict(columns, pressure=pressure, von_mises=von_mises)
