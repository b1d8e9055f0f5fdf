"""The material state of a material point, as one record the kernels receive whole.

Particles and the elements of FEM bodies keep these columns (first axis the point);
every material kernel reads and updates them through one ``MaterialState``, which Numba
passes as a tuple of arrays at no cost.
"""
from collections import namedtuple

import numpy as np

#: stress (n, 6) Voigt xx yy zz xy yz zx; F (n, 9) deformation gradient, row-major;
#: rho (n,) current density; eps_p (n,) equivalent plastic strain; e_int (n,) specific
#: internal energy; temp (n,) temperature; q (n,) artificial bulk viscosity pressure;
#: damage (n,) damage D (0 intact, 1 failed: Johnson-Cook D, or eps_p / eps_fail);
#: w_p (n,) specific plastic work, sum of sigma_y d eps_p / rho (energy per mass, a part
#: of e_int).
MaterialState = namedtuple("MaterialState", "stress F rho eps_p e_int temp q damage w_p")

#: the column names of the record, in its order (they are also the particle columns)
MATERIAL_COLUMNS = MaterialState._fields

#: columns a checkpoint written before they existed lacks: they start at 0
LATER_COLUMNS = ("damage", "w_p")


def with_later_columns(columns, n):
    """``columns`` (name -> array) with zero ``damage`` and ``w_p`` added where missing
    (a checkpoint written before damage and plastic work were kept)."""
    extra = {name: np.zeros(n) for name in LATER_COLUMNS if name not in columns}
    return dict(columns, **extra) if extra else columns
