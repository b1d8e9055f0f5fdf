"""Slots of a packed material parameter row and the integer codes of the models.

A body's material is packed into one float64 row of ``N_SLOTS`` values so that the
fused stress kernel can dispatch on ``MODEL_*`` and read parameters by slot. Slots a
model does not use stay 0. This module is plain Python (no Numba) so that the case
layer and the kernels agree on it without importing each other.
"""

# model codes
ELASTIC = 0
NEO_HOOKEAN = 1
J2_PLASTIC = 2          # j2_linear and j2_power: sigma_y = A + B * eps_p**n
JOHNSON_COOK = 3        # (A + B eps_p^n)(1 + C ln eps_dot*)(1 - T*^m)
FLUID = 4
RIGID = 5

# EOS codes (slot EOS_TYPE)
EOS_NONE = 0            # hypoelastic pressure from the bulk modulus K
EOS_MIE_GRUNEISEN = 1   # seed 001 Eq. 38
EOS_LINEAR = 2          # p = rho0 c0^2 mu (mu = rho/rho0 - 1); "incompressible" water of seed 004 Sec. 4.4

# damage model codes (slot DAMAGE)
DAMAGE_NONE = 0         # no damage model (eps_fail, if set, is the only failure)
DAMAGE_JOHNSON_COOK = 1 # D += d eps_p / eps_f(triaxiality, rate, T*), fails at D = 1

# slots
RHO0 = 0
E = 1
NU = 2
G = 3
K = 4
A = 5                   # initial yield stress
B = 6                   # hardening modulus
N = 7                   # hardening exponent
C = 8                   # Johnson-Cook strain-rate constant
EPS_DOT0 = 9            # reference plastic strain rate (1/time)
M = 10                  # thermal softening exponent (0: no softening)
T_ROOM = 11
T_MELT = 12
CP = 13                 # specific heat (energy / (mass K))
CHI = 14                # Taylor-Quinney factor
EOS_TYPE = 15
EOS_C0 = 16
EOS_S = 17
EOS_GAMMA0 = 18
EPS_FAIL = 19           # equivalent plastic strain at failure (0: never)
Q_LINEAR = 20           # artificial bulk viscosity, linear coefficient
Q_QUADRATIC = 21        # artificial bulk viscosity, quadratic coefficient
VISCOSITY = 22          # dynamic viscosity of a fluid (stress * time)
TENSION_CUTOFF = 23     # largest tension (positive number) a fluid sustains
DAMAGE = 24             # damage model code (DAMAGE_NONE, DAMAGE_JOHNSON_COOK)
D1 = 25                 # Johnson-Cook fracture strain constants D1..D5
D2 = 26
D3 = 27
D4 = 28
D5 = 29
SPALL = 30              # spall pressure: a tension beyond it fails the point (0: none)
N_SLOTS = 31
