"""Two identical elastic spheres meeting head-on, or a sphere dropped on a half-space of
its own material: Hertz's answer and the measured one.

Each sphere has radius R, density rho, Young's modulus E, Poisson's ratio nu and speed v
towards the other (relative speed 2v). Hertz (Johnson, Contact Mechanics, Sec. 11.4) with
the effective radius R/2, modulus E / (2 (1 - nu^2)) and mass m/2 gives the largest
approach of the centres, the peak force and the contact time. Units: mm, ms, g (force in
N, energy in mJ = N mm).
"""
import math
from collections import namedtuple

import numpy as np

from .contact import read_history

HertzAnswer = namedtuple("HertzAnswer", "mass approach force contact_time radius")


def hertz_answer(radius, density, young, poisson, speed, on_half_space=False):
    """Hertz's largest approach (mm), peak force (N), contact time (ms) and largest
    contact radius (mm) for two identical spheres, each of mass ``mass`` (g), each at
    ``speed`` towards the other; or (``on_half_space``) for one sphere at ``speed`` onto
    a half-space of the same material (effective mass m, radius R, relative speed v)."""
    mass = density * 4.0 / 3.0 * math.pi * radius ** 3
    if on_half_space:
        m_eff, r_eff, relative = mass, radius, speed
    else:
        m_eff, r_eff, relative = mass / 2.0, radius / 2.0, 2.0 * speed
    e_eff = young / (2.0 * (1.0 - poisson ** 2))
    approach = (15.0 * m_eff * relative ** 2 / (16.0 * e_eff * math.sqrt(r_eff))) ** 0.4
    force = 4.0 / 3.0 * e_eff * math.sqrt(r_eff) * approach ** 1.5
    contact_time = 2.868 * (m_eff ** 2 / (r_eff * e_eff ** 2 * relative)) ** 0.2
    return HertzAnswer(mass, approach, force, contact_time,
                       math.sqrt(r_eff * approach))


#: Contact is counted while the measured force exceeds this fraction of its peak.
TOUCHING = 0.02


def hertz_share_above(fraction):
    """The share of Hertz's contact time during which the force exceeds ``fraction`` of
    its peak. The approach obeys m delta'' = -K delta^(3/2), so the time to reach
    delta = x delta_max is (delta_max / v) int_0^x (1 - s^(5/2))^(-1/2) ds, and the force
    passes fraction F_max at x = fraction^(2/3), once on the way in and once on the way
    out (0.950 at 2 %: a run exact to the digit would be 5 % short of the whole time)."""
    n = 2.5
    whole = math.gamma(1.0 / n) * math.gamma(0.5) / (n * math.gamma(1.0 / n + 0.5))
    s = np.linspace(0.0, fraction ** (2.0 / 3.0), 2001)
    f = (1.0 - s ** n) ** -0.5
    ramp = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(s)))
    return 1.0 - ramp / whole


def hertz_measures(out_dir, answer, radius, lower="lower", upper="upper"):
    """Peak force, contact time and largest approach of a run (history every step or
    so), each as the ratio to ``answer``'s minus 1; also the rebound speed over the
    impact speed and the change of the total energy. The force is the lower sphere's
    mass times the rate of change of its mean velocity over a window of about 1/40 of
    Hertz's contact time; contact lasts while that force exceeds 2 % of its peak
    (:data:`TOUCHING`), and is compared with the time Hertz's force does
    (:func:`hertz_share_above`); the approach is 2 R less the distance between the
    centroids (the quarter or whole spheres' centroids lie on the axis)."""
    hist = read_history(out_dir)
    v = hist[f"{lower}.vz"]
    measured = _pulse(hist["time"], -v, answer)
    approach = 2.0 * radius - (hist[f"{upper}.z"] - hist[f"{lower}.z"])
    return {**measured, "approach": approach.max() / answer.approach - 1.0,
            "rebound": -v[-1] / v[0],
            "energy": hist["total"][-1] / hist["total"][0] - 1.0}


def dropped_sphere_measures(out_dir, answer, sphere="sphere"):
    """The figures of :func:`hertz_measures` (not the approach) for a sphere dropped
    along -z on a half-space (``hertz_answer(..., on_half_space=True)``): its force from
    the rate of change of its mean velocity, the contact time, the rebound speed over
    the impact speed and the change of the total energy."""
    hist = read_history(out_dir)
    v = hist[f"{sphere}.vz"]
    return {**_pulse(hist["time"], v, answer), "rebound": -v[-1] / v[0],
            "energy": hist["total"][-1] / hist["total"][0] - 1.0}


def _pulse(t, v, answer):
    """Peak force and contact time against Hertz's, from a body's mean velocity ``v``
    along the direction the contact pushes it (mass ``answer.mass``)."""
    window = max(1, int(round(answer.contact_time / 40 / np.median(np.diff(t)))))
    force = answer.mass * (v[window:] - v[:-window]) / (t[window:] - t[:-window])
    mid = 0.5 * (t[window:] + t[:-window])
    touching = np.flatnonzero(force > TOUCHING * force.max())
    contact_time = mid[touching[-1]] - mid[touching[0]]
    return {"force": force.max() / answer.force - 1.0,
            "contact_time": contact_time / (answer.contact_time
                                             * hertz_share_above(TOUCHING)) - 1.0}
