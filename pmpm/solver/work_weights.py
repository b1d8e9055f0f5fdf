"""What a point costs to step, in particle-steps of the case's shape function: the weight
each FEM element counts with in the slabs' balance (the initial cut and every rebalance;
issue 24). A particle counts 1, so particle-only cases cut exactly as before.

An element-step costs more than a hat particle-step and less than a 27-node one: the
ratio depends on the element formulation and on the particles' shape functions (a
27-node particle touches 27 nodes where a hat touches 8). The costs below were measured once, on one rank, with
``scripts/element_weights.py``: the same copper block (Johnson-Cook + Mie-Grueneisen +
bulk viscosity, 190 m/s onto a slip wall) as 125,000 particles with each shape function
and as 125,000 hexahedra with each formulation, the variants interleaved, medians of 3
repeats (the project's 2-core x86_64 machine, 2026-12-05 08:47-08:58 UTC with one other
job on the second core; after the FE nodes' force log and the element blocks lost
Numba's reference counting in their loops, which cut an element-step by about a third;
docs/performance-notes.md "Elements in the rebalance (issue 24)"). The weights they give:

=================  ======  =====  =======
element            linear  gimp   bspline
=================  ======  =====  =======
reduced, viscous   1.5     0.75   0.75
reduced, stiffness 1.5     0.75   0.75
assumed_strain     2.75    1.5    1.5
rigid              0.25    0.25   0.25
=================  ======  =====  =======

A rigid FEM body's elements are not stepped (pmpm.fem.elements skips them); its nodes
still are. Contact, coupling and the material change these ratios (an elastic striker
on an elastic bar steps cheaper than the Johnson-Cook block, its particles more so); the
table holds the step itself.

The weights are fixed numbers, never timings of the running case: a run cuts its slabs
the same way every time, on every machine. They are rounded to quarters, so that the
weighted histograms are sums of exact binary fractions: the same in any order of
summation, over any number of ranks.
"""
import numpy as np

#: seconds per particle-step by shape function (scripts/element_weights.py, medians of 3;
#: one other job on the second core: samples within 5 % of their median)
PARTICLE_STEP_S = {"linear": 0.146e-6, "gimp": 0.286e-6, "bspline": 0.274e-6}
#: seconds per element-step by element formulation (the same runs): the reduced element
#: with viscous or stiffness hourglass control, the assumed-strain element, a rigid body
ELEMENT_STEP_S = {"reduced_viscous": 0.234e-6, "reduced_stiffness": 0.234e-6,
                  "assumed_strain": 0.408e-6, "rigid": 0.027e-6}
#: the resolution of the weights (see the module's docstring)
QUANTUM = 0.25


def formulation(fem, rigid):
    """The ELEMENT_STEP_S key of an FEM body's ``fem`` (pmpm.case.FemConfig)."""
    if rigid:
        return "rigid"
    if fem.element == "assumed_strain":
        return "assumed_strain"
    return f"reduced_{fem.hourglass}"


def element_weight(fem, rigid, shape):
    """One element-step of this formulation in particle-steps of ``shape``, rounded to a
    quarter (at least one quarter)."""
    ratio = ELEMENT_STEP_S[formulation(fem, rigid)] / PARTICLE_STEP_S[shape]
    return max(QUANTUM, QUANTUM * round(ratio / QUANTUM))


def body_weights(config, rigid):
    """Per body of ``config`` the weight of one of its points: an FEM body's element
    weight, 1 for a particle body. ``rigid``: bool per body (solver.bodies.BodyTable)."""
    shape = config.grid.shape_functions
    return np.array([element_weight(b.fem, rigid[i], shape) if b.is_fem else 1.0
                     for i, b in enumerate(config.bodies)])
