"""Issue 24: elastic impacts through particle-to-surface contact (ICFEMP) keep their
energy and carry the contact force (docs/validation/surface_contact_impact.md has the
figures, before and after):

* tests/cases/sphere_on_fem_block.yaml at the users' resolution (1 mm cells and elements,
  5 per sphere radius; about 2 across Hertz's contact patch): the steel particle sphere
  dropped at 50 m/s on the steel FEM block;
* tests/cases/striker_on_fem_bar.yaml: a particle striker end-on on an FEM bar of the
  same steel, 1D: the bar carries a pulse of rho c v / 2 and length 2 Ls, and the
  striker stops after 2 Ls / c."""
import math
import os

import numpy as np
import pytest

from pmpm.post.hertz import hertz_share_above

HERE = os.path.dirname(os.path.abspath(__file__))


def set_up_case(name, overrides=(), world=None):
    from runhelp import set_up
    return set_up(os.path.join(HERE, "cases", name), overrides, world)


def simulation(overrides=(), world=None):
    return set_up_case("sphere_on_fem_block.yaml", overrides, world)


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


def test_no_contact_face_lies_on_a_plane_of_symmetry():
    """The quarter block's faces on x = 0 and y = 0 (planes of symmetry) and on z = 0
    (fixed) are interior or held: no contact faces (they pulled the sphere's particles
    beside them onto the plane, 0.12 mm deep at 0.5 mm cells); its top and outer sides
    are."""
    sim = simulation()
    faces = sim.elements.x[sim.surface.face_nodes]
    on_plane = [(np.abs(faces[:, :, d]) < 1e-9).all(axis=1) for d in range(3)]
    assert not np.any(on_plane[0] | on_plane[1] | on_plane[2])
    assert (np.abs(faces[:, :, 2] - 8.0) < 1e-9).all(axis=1).sum() == 100   # 10 x 10 top
    assert (np.abs(faces[:, :, 0] - 10.0) < 1e-9).all(axis=1).sum() == 80   # 10 x 8 side


def test_an_elastic_sphere_rebounds_from_an_fem_block_with_its_energy():
    """Hertz, sphere on a half-space: 46.9 kN, 16.1 us. Measured at 1 mm (the contact
    on the sphere's grid, issue 24 Sec. 4): energy +2.8 % at the end (-3.1 % at its
    lowest, +4.0 % at its highest, while the sphere leaves), rebound 0.99 of the impact
    speed, one smooth force pulse, peak force +41 %, contact time -40 %: stiffer than
    Hertz, as the grid's nodes and the block's face nodes make the contact patch a cell
    wide where Hertz's is 2.3 mm across (0.5 mm: +16 %, -25 %). Before (the impulse on
    the particle alone): -9 % and +11 %, but from a force that rose to 27 % of Hertz's,
    fell back to 5 % and rose again, the sphere sinking 0.34 mm (Hertz: 0.27), and
    rebound 0.88. Tolerances: energy within 4 % at the end and never 5 % above its
    start, rebound above 0.9, one pulse (the force is above a quarter of its peak over
    one stretch of time), force within 50 % and contact time within 45 %."""
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
    assert abs(total[-1] / e0 - 1.0) < 0.04 and total.max() <= e0 * 1.05
    assert vz[-1] / 50.0 > 0.9                          # rebounds upwards
    loaded = np.flatnonzero(f > 0.25 * f.max())
    assert np.all(np.diff(loaded) == 1)                 # one pulse
    assert abs(f.max() / force - 1.0) < 0.5
    assert abs(span - 1.0) < 0.45


def striker_run(cell, shapes, t_profile=0.008, end=0.012, cfl=0.5):
    """The striker on the FEM bar: (times, the striker's mean vx after every step, and
    the bar's element centroids x and axial stresses at ``t_profile``)."""
    sim = set_up_case("striker_on_fem_bar.yaml", [f"params.cell={cell}",
                                                  f"grid.shape_functions={shapes}"])
    rows, profile = [], None
    while sim.time < end - 1e-12:
        sim.advance(min(cfl * sim.grid.h / sim.fastest_speed(), end - sim.time))
        p = sim.particles
        b = p.body == 0
        rows.append((sim.time, p.mass[b] @ p.v[b, 0] / p.mass[b].sum()))
        if profile is None and sim.time >= t_profile - 1e-12:
            fem = sim.elements
            profile = fem.centroids()[:, 0].copy(), fem.state.stress[:, 0].copy()
    return np.array(rows), profile


@pytest.mark.parametrize("cell, shapes", [(0.5, "linear"), (1.0, "gimp")])
def test_a_striker_sends_its_plane_wave_into_an_fem_bar(cell, shapes):
    """1D (nu 0, slip faces), E = 100 GPa, rho = 5 g/cm^3 (c = 4472 m/s), striker 10 mm
    at 10 m/s: the bar carries rho c v / 2 = 111.8 MPa over 2 Ls = 20 mm, and the
    striker stops after 2 Ls / c = 4.47 us. Measured (0.5 mm linear / 1 mm gimp): plateau
    (median stress where it exceeds half of rho c v / 2, at 8 us) 0.986 / 0.959, pulse
    length there 0.999 / 0.949 of 2 Ls, striker stop (mean speed below 2 % of v) 1.003 /
    1.014 x 2 Ls / c, final speed -0.014 / -0.023 v (the particle bar through grid
    contact: 0.977 / 0.929, 0.986 / 0.974, 1.02 / 1.07 at 0.5 / 1 mm, linear). Before issue
    24 Sec. 4 (0.5 mm): plateau 0.67 (linear) and 0.60 (gimp), a pulse 0.22 and 1.72 of
    2 Ls, the striker never stopping (linear) or stopping at 2.5 x 2 Ls / c (gimp).
    Tolerances: plateau and pulse length within 7 %, stop within 5 %, final speed below
    5 % of v."""
    rows, (x, stress) = striker_run(cell, shapes)
    c, v0 = math.sqrt(1.0e5 / 5.0e-3), 10.0
    sigma = 5.0e-3 * c * v0 / 2.0
    loaded = -stress > 0.5 * sigma
    plateau = np.median(-stress[loaded]) / sigma
    length = (x[loaded].max() - x[loaded].min()) / 20.0
    stopped = np.flatnonzero(rows[:, 1] < 0.02 * v0)
    assert len(stopped), "the striker never stops"
    stop = rows[stopped[0], 0] / (2 * 10.0 / c)
    assert abs(plateau - 1.0) < 0.07
    assert abs(length - 1.0) < 0.07
    assert abs(stop - 1.0) < 0.05
    assert abs(rows[-1, 1]) < 0.05 * v0


def surface_rows_at(sim, z, normal=(0.0, 0.0, 1.0)):
    """The rows (node -> weight) that ``surface_nodes`` gives a sphere particle moved to
    (0.3, 0.3, z) with its face's normal ``normal``."""
    from pmpm.kernels import surface_contact as ksc
    state = next(iter(sim.surface.grids))
    p = np.flatnonzero(sim.particles.body == 1)[:1]
    x = sim.particles.x.copy()
    x[p[0]] = (0.3, 0.3, z)
    node, pair, weight = (np.empty(27, np.int64), np.empty(27, np.int64), np.empty(27))
    n = ksc.surface_nodes(x, p, sim.particles.body, np.array([normal]), state.geometry,
                          node, pair, weight)
    return dict(zip(node[:n].tolist(), weight[:n].tolist()))


@pytest.mark.parametrize("shapes", ["gimp", "linear"])
def test_a_particle_crossing_a_node_plane_keeps_its_surface_weights(shapes):
    """The grid nodes that stand for the particle body's surface at a pair are weighted
    by N_Ip times a ramp of the node's height over the particle along the face's normal
    (1 half the particle's width or more nearer the face, 0 as far beyond): a particle
    moved by 2e-6 cells across a node plane changes its rows' weights by about that
    (1e-5 with 2 particles per cell). Before, a
    node counted fully while at or below the particle and not at all once above it, so
    the weights jumped by a quarter to a half as the particle crossed the plane (the
    sphere at 0.25 mm gained a quarter of its energy; next test)."""
    sim = simulation(["params.cell=1.0", f"grid.shape_functions={shapes}"])
    sim.advance(0.5 * sim.grid.h / sim.fastest_speed())
    below, above = surface_rows_at(sim, 8.0 - 1e-6), surface_rows_at(sim, 8.0 + 1e-6)
    nodes = set(below) | set(above)
    jump = max(abs(below.get(i, 0.0) - above.get(i, 0.0)) for i in nodes)
    assert jump < 1e-4
    assert abs(sum(below.values()) - 1.0) < 1e-12 and abs(sum(above.values()) - 1.0) < 1e-12


@pytest.mark.parametrize("cell, speed", [(1.0, 150.0), (0.5, 100.0)])
def test_a_sphere_whose_lowest_layer_crosses_a_node_plane_keeps_its_energy(cell, speed):
    """The sphere faster than the 50 m/s above: the block's top under it goes down 0.24
    mm (1 mm cells, 150 m/s: the users' resolution, 5 cells across the radius) or 0.19
    mm (0.5 mm, 100 m/s), more than the sphere's lowest particle layer stands above a
    node plane (0.25 and 0.125 mm), so the layer crosses the plane during the contact.
    Measured: energy -4.8 % / +0.6 % at the end (-4.8 % / -10.0 % at its lowest),
    rebound 0.94 / 0.98. Before the surface nodes' ramp (above) the energy grew by 72 % /
    47 % (the lowest layer crushed as the node plane under it stopped standing for the
    surface). Tolerances: energy within 10 % at the end and never 5 % above its start,
    rebound above 0.9, no particle lost."""
    sim = simulation([f"params.cell={cell}", f"params.v={speed}"])
    e0 = sim.energies()["total"]
    rows = sphere_history(sim)
    _, vz, total = rows.T
    assert sim.lost == 0
    assert abs(total[-1] / e0 - 1.0) < 0.10 and total.max() <= e0 * 1.05
    assert vz[-1] / speed > 0.9


def test_a_fast_rebound_stays_in_the_grid_and_keeps_its_energy():
    """200 m/s at the users' 1 mm: the sphere rebounds at 0.93 v and travels 3.7 mm
    before 30 us. The case's box reached 2 cells above the sphere, and by 30 us 110 of
    its 1056 particles had left the grid, taking 10 % of the energy with them: what was
    read as the contact's loss (-17.8 %). With the headroom of v times time.end the
    energy at the end is -8.1 % (-12.6 % at its lowest, during the contact), no particle
    leaves. Tolerances: no particle lost, energy within 10 % at the end, rebound above
    0.9."""
    sim = simulation(["params.v=200"])
    e0 = sim.energies()["total"]
    _, vz, total = sphere_history(sim).T
    assert sim.lost == 0
    assert abs(total[-1] / e0 - 1.0) < 0.10
    assert vz[-1] / 200.0 > 0.9


def test_grid_contact_between_particle_spheres_does_not_gain_energy_as_they_part():
    """The grid-contact reference of the sphere (the block as particles, contact method
    2, the defaults' release rule and volume gap), moved 0.1 mm against the particle
    lattice: with the paper's end-of-step correction of bodies that separated at the
    step's start (`contact.skip_separating: false`) the sphere left at 1.10 times its
    impact speed with 36 % more energy than it came with, all of it gained while it
    parted. The default (`auto`: the frictionless pairs, as here) leaves them
    uncorrected: measured energy +4.9 %, rebound 0.98. Tolerances: energy within 10 % at
    the end and rebound between 0.9 and 1.02 under the default; above both with the
    paper's rule."""
    sets = ["params.gap=0.1", "bodies[0].method=particles", "bodies[0].fem={}",
            "bodies[0].particles_per_cell=2", "contact.method=2"]
    for skip, gains in (([], False), (["contact.skip_separating=false"], True)):
        sim = simulation(sets + skip)
        e0 = sim.energies()["total"]
        _, vz, total = sphere_history(sim).T
        assert sim.lost == 0
        if gains:
            assert total[-1] / e0 - 1.0 > 0.10 and vz[-1] / 50.0 > 1.02
        else:
            assert abs(total[-1] / e0 - 1.0) < 0.10 and 0.9 < vz[-1] / 50.0 < 1.02
