"""Issue 24: an elastic impact through particle-to-surface contact (ICFEMP) keeps its
energy. tests/cases/sphere_on_fem_block.yaml at the users' resolution (1 mm cells and
elements, 5 per sphere radius; about 2 across Hertz's contact patch): the steel particle
sphere dropped at 50 m/s on the steel FEM block (docs/validation/surface_contact_impact.md
has the figures at 1 and 0.5 mm, before and after)."""
import math
import os

import numpy as np

from pmpm.post.hertz import hertz_share_above

HERE = os.path.dirname(os.path.abspath(__file__))


def simulation(overrides=(), world=None):
    from runhelp import set_up
    return set_up(os.path.join(HERE, "cases", "sphere_on_fem_block.yaml"), overrides, world)


def hertz_sphere_on_flat(radius=5.0, density=7.85e-3, young=2.0e5, poisson=0.3, speed=50.0):
    """(mass, peak force, contact time) of a sphere on a half-space of its material."""
    mass = density * 4.0 / 3.0 * math.pi * radius ** 3
    e_eff = young / (2.0 * (1.0 - poisson ** 2))
    approach = (15.0 * mass * speed ** 2 / (16.0 * e_eff * math.sqrt(radius))) ** 0.4
    force = 4.0 / 3.0 * e_eff * math.sqrt(radius) * approach ** 1.5
    time = 2.868 * (mass ** 2 / (radius * e_eff ** 2 * speed)) ** 0.2
    return mass, force, time


def sphere_history(sim, end=0.03, cfl=0.5):
    """(time, the sphere's mean vz, total energy) after every step."""
    rows = []
    while sim.time < end - 1e-12:
        sim.advance(min(cfl * sim.grid.h / sim.fastest_speed(), end - sim.time))
        p = sim.particles
        b = p.body == 1
        vz = sim.world.sum(np.array([p.mass[b] @ p.v[b, 2], p.mass[b].sum()]))
        rows.append((sim.time, vz[0] / vz[1], sim.energies()["total"]))
    return np.array(rows)


def test_an_elastic_sphere_rebounds_from_an_fem_block_with_its_energy():
    """Hertz, sphere on a half-space: 46.9 kN, 16.1 us. Measured at 1 mm: energy -0.1 %
    (before issue 24: -77 %), rebound 0.87 of the impact speed (0.32), peak force -11 %,
    contact time +29 % (the block's finite depth and its waves, and 2 cells across the
    patch). Tolerances: energy within 2 %, rebound above 0.8, force within 20 %, contact
    time within 40 %."""
    sim = simulation()
    e0 = sim.energies()["total"]
    rows = sphere_history(sim)
    t, vz, total = rows.T
    mass, force, time = hertz_sphere_on_flat()
    window = max(1, int(round(time / 40 / np.median(np.diff(t)))))
    f = mass * (vz[window:] - vz[:-window]) / (t[window:] - t[:-window])
    mid = 0.5 * (t[window:] + t[:-window])
    touching = np.flatnonzero(f > 0.02 * f.max())
    span = (mid[touching[-1]] - mid[touching[0]]) / (time * hertz_share_above(0.02))
    assert abs(total[-1] / e0 - 1.0) < 0.02 and total.max() <= e0 * 1.02
    assert vz[-1] / 50.0 > 0.8                          # rebounds upwards
    assert abs(f.max() / force - 1.0) < 0.2
    assert abs(span - 1.0) < 0.4
