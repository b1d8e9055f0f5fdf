"""The material state of a material point, as one record the kernels receive whole.

Particles today, and the integration points of finite elements tomorrow, keep these
columns (first axis the point); every material kernel reads and updates them through
one ``MaterialState``, which Numba passes as a tuple of arrays at no cost.
"""
from collections import namedtuple

#: stress (n, 6) Voigt xx yy zz xy yz zx; F (n, 9) deformation gradient, row-major;
#: rho (n,) current density; eps_p (n,) equivalent plastic strain; e_int (n,) specific
#: internal energy; temp (n,) temperature; q (n,) artificial bulk viscosity pressure.
MaterialState = namedtuple("MaterialState", "stress F rho eps_p e_int temp q")

#: the column names of the record, in its order (they are also the particle columns)
MATERIAL_COLUMNS = MaterialState._fields
