"""Johnson-Cook damage, failure, the spall cut-off and plastic work (issue 26).

At one material point the kernel is driven along paths whose answer is known in closed
form: isochoric extension from a state on the yield surface, with a constant hydrostatic
stress, keeps the triaxiality, the plastic strain rate and the temperature constant, so
the damage is D = eps_p / eps_f exactly (Johnson and Cook 1985), and under linear
hardening the plastic work is the integral of sigma_y d eps_p. The same update runs in a
hexahedron (pmpm.fem.elements), a converted element's particles inherit its damage and
plastic work, and a run continued from a checkpoint carries both on.
Damage constants: 4340 steel, Johnson and Cook (1985), Eng. Fract. Mech. 21, 31-48.
Units: mm, ms, g (MPa, 1/ms).
"""
import json
import math
import os

import h5py
import numpy as np
import pytest

from pmpm.materials import catalog
from pmpm.materials import layout as L
from pmpm.materials.kernels import update_stress
from pmpm.materials.state import MaterialState

HERE = os.path.dirname(os.path.abspath(__file__))
CASE = os.path.join(HERE, "cases", "damage_impact.yaml")
JC4340 = dict(d1=0.05, d2=3.44, d3=-2.12, d4=0.002, d5=0.61)
T_ROOM, T_MELT = 293.0, 1793.0
STEEL = dict(model="johnson_cook", density=7.85e-3, E=200e3, nu=0.30, A=600.0, B=0.0,
             n=1.0, C=0.0, eps_dot0=1e-3, T_room=T_ROOM, T_melt=T_MELT)
#: extension along x, isochoric: D = r diag(1, -1/2, -1/2), von Mises strain rate r
EXTENSION = np.diag([1.0, -0.5, -0.5])


def steel(**damage):
    return dict(STEEL, damage=dict(model="johnson_cook", **damage))


def on_yield_surface(sigma_y, mean_stress):
    """Voigt stress with the extension's deviator at von Mises ``sigma_y`` plus
    ``mean_stress`` (tension positive)."""
    s = sigma_y * np.array([2.0, -1.0, -1.0, 0, 0, 0]) / 3.0
    return s + mean_stress * np.array([1.0, 1.0, 1.0, 0, 0, 0])


class Point:
    """One material point's columns, stepped through update_stress."""

    def __init__(self, material, stress=None, temp=T_ROOM):
        self.code, self.prm = catalog.pack(material)
        n1 = [np.zeros(1) for _ in range(6)]
        self.mat = MaterialState(np.zeros((1, 6)), np.eye(3).reshape(1, 9).copy(),
                                 np.array([self.prm[L.RHO0]]), *n1)
        self.mat.temp[0] = temp
        if stress is not None:
            self.mat.stress[0] = stress

    def step(self, Lg, dt):
        c = update_stress(0, self.code, self.prm, dt, 1.0, np.ascontiguousarray(Lg),
                          self.mat)
        assert c > 0.0
        return c

    def __getattr__(self, name):
        return getattr(self.mat, name)[0]

    @property
    def pressure(self):
        return -self.mat.stress[0, :3].sum() / 3.0

    @property
    def deviator(self):
        s = self.mat.stress[0].copy()
        s[:3] += self.pressure
        return s


def fracture_strain(triax, rate_ratio, t_star, d1, d2, d3, d4, d5):
    """Johnson-Cook (1985) Eq. 4, written out here independently of the kernel."""
    return ((d1 + d2 * math.exp(d3 * triax)) * (1 + d4 * math.log(max(rate_ratio, 1.0)))
            * (1 + d5 * t_star))


# ---------------------------------------------------------------- one material point

@pytest.mark.parametrize("triax", [1.0 / 3.0, 0.0, -1.0 / 3.0])
def test_damage_at_constant_triaxiality_is_plastic_strain_over_fracture_strain(triax):
    """Fully plastic isochoric extension at 1e4/s (perfectly plastic, so the flow stress,
    the hydrostatic stress and the triaxiality stay put), T* = 1/3: D = eps_p / eps_f
    with every factor of eps_f in play, to round-off. The sign of the triaxiality
    matters: in tension (1/3) the point fails 4 times sooner than in compression."""
    rate, dt, n = 10.0, 2e-4, 100                   # 1/ms: 1e4/s; eps_p 2e-3 per step
    temp = T_ROOM + (T_MELT - T_ROOM) / 3.0
    point = Point(steel(**JC4340), on_yield_surface(600.0, triax * 600.0), temp)
    for _ in range(n):
        point.step(rate * EXTENSION, dt)
    eps_f = fracture_strain(triax, rate / 1e-3, 1.0 / 3.0, **JC4340)
    assert point.eps_p == pytest.approx(n * rate * dt, rel=1e-12)      # round-off
    assert point.damage == pytest.approx(point.eps_p / eps_f, rel=1e-12)
    assert point.pressure == pytest.approx(-triax * 600.0, abs=1e-9)
    # plastic work per mass: sigma_y eps_p / rho (perfectly plastic, isochoric)
    assert point.w_p == pytest.approx(600.0 * point.eps_p / 7.85e-3, rel=1e-12)


def test_a_point_fails_at_d_equal_1_and_keeps_no_deviator_and_no_tension():
    """Triaxiality 1: eps_f = 0.567 at 1e4/s, room temperature. The point fails in the
    step where eps_p reaches eps_f: from then on no deviator and no tension, its plastic
    strain frozen; it still carries compression."""
    rate, dt = 10.0, 1e-3                           # eps_p 0.01 per step
    point = Point(steel(**JC4340), on_yield_surface(600.0, 600.0))
    eps_f = fracture_strain(1.0, 1e4, 0.0, **JC4340)
    steps = 0
    while point.damage < 1.0:
        point.step(rate * EXTENSION, dt)
        steps += 1
        assert steps < 100
    assert steps == math.ceil(eps_f / (rate * dt))
    assert point.damage == 1.0
    assert np.all(point.deviator == 0.0) and point.pressure == 0.0     # was -600
    eps = point.eps_p
    for _ in range(5):                             # stretched further, and dilated
        point.step(rate * EXTENSION + 0.1 * np.eye(3), dt)
        assert np.all(point.deviator == 0.0) and point.pressure == 0.0
    assert point.eps_p == eps
    point.step(-0.5 * np.eye(3), dt)               # compressed: the bulk modulus holds
    K = 200e3 / (3 * (1 - 2 * 0.3))
    assert point.pressure == pytest.approx(K * 1.5 * dt, rel=1e-12)


def test_eps_fail_keeps_seed_001s_rule_and_reports_eps_p_over_eps_fail_as_damage():
    """The constant failure strain (seed 001 Sec. 5.3): damage is eps_p / eps_fail, and
    the failed point loses its deviator but keeps its tension."""
    material = dict(STEEL, eps_fail=0.05)
    point = Point(material, on_yield_surface(600.0, 300.0))
    point.step(10.0 * EXTENSION, 1e-3)
    assert point.damage == pytest.approx(point.eps_p / 0.05, rel=1e-15) and point.damage < 1
    for _ in range(5):
        point.step(10.0 * EXTENSION, 1e-3)
    assert point.damage == 1.0 and np.all(point.deviator == 0.0)
    assert point.pressure == pytest.approx(-300.0, rel=1e-12)


@pytest.mark.parametrize("spall", [950.0, 0.0])
def test_the_spall_cut_off_fails_a_point_in_hydrostatic_tension(spall):
    """Elastic hydrostatic dilatation, 166.7 MPa of tension per step: no deviator, so no
    plastic strain and no Johnson-Cook damage. With spall_pressure 950 MPa the point
    fails in the step whose pressure passes -950 (the 6th, at -1000): pressure 0 and
    damage 1 from then on; without the cut-off it goes on in tension."""
    point = Point(steel(**JC4340, spall_pressure=spall))
    K = 200e3 / (3 * (1 - 2 * 0.3))
    dt, rate = 1e-3, 1e-3 / 3 / 1e-3               # 3 rate dt = 1e-3 per step
    for k in range(1, 6):
        point.step(rate * np.eye(3), dt)
        assert point.pressure == pytest.approx(-K * 1e-3 * k, rel=1e-9)
        assert point.damage == 0.0
    point.step(rate * np.eye(3), dt)
    if spall:
        assert point.damage == 1.0 and point.pressure == 0.0
        point.step(rate * np.eye(3), dt)
        assert point.pressure == 0.0
    else:
        assert point.damage == 0.0 and point.pressure == pytest.approx(-K * 6e-3, rel=1e-9)
    assert point.eps_p == 0.0


def test_plastic_work_under_linear_hardening_is_the_integral_of_the_flow_stress():
    """j2_linear, isochoric extension from the yield surface: each step's increment is
    dlam = 3G r dt / (3G + H), the flow stress A + H eps_p, so the plastic work per
    volume is A eps_p + H eps_p^2 / 2 plus the end-of-step rule's H eps_p dlam / 2
    (exactly, for a constant increment)."""
    material = dict(model="j2_linear", density=7.85e-3, E=200e3, nu=0.3, yield_stress=300.0,
                    tangent_modulus=2000.0)
    point = Point(material, on_yield_surface(300.0, 0.0))
    code, prm = catalog.pack(material)
    G, H = prm[L.G], prm[L.B]
    rate, dt, n = 10.0, 1e-3, 200
    for _ in range(n):
        point.step(rate * EXTENSION, dt)
    dlam = 3 * G * rate * dt / (3 * G + H)
    eps = point.eps_p
    assert eps == pytest.approx(n * dlam, rel=1e-12)
    integral = 300.0 * eps + 0.5 * H * eps ** 2
    bias = 0.5 * H * eps * dlam
    assert point.w_p * 7.85e-3 == pytest.approx(integral + bias, rel=1e-12)
    assert point.w_p * 7.85e-3 - integral < 1.001 * bias       # the bias is first order
    assert point.damage == 0.0                                 # no damage model


# ---------------------------------------------------------------- case keys

def read(material):
    from pmpm.case.materials import MATERIALS

    class Problems(list):
        def add(self, path, message):
            self.append(f"{path}: {message}")
    problems = Problems()
    MATERIALS({"m": material}, "materials", problems)
    return problems


def test_damage_keys_are_checked_naming_the_key():
    assert read(steel(**JC4340, spall_pressure=1e3)) == []
    assert read(dict(steel(**JC4340), eps_fail=0.5)) == [
        "materials.m.damage: give either eps_fail or damage, not both (the damage model "
        "decides failure)"]
    power = dict(model="j2_power", density=1.0, E=1.0, nu=0.3, A=1.0, B=1.0, n=1.0,
                 damage=dict(model="johnson_cook", d1=0.1, d2=1.0, d3=-1.0, d5=0.5))
    assert read(power) == ["materials.m.damage.d5: must be 0 with model 'j2_power': it "
                           "needs a homologous temperature (T_room, T_melt), which only "
                           "model 'johnson_cook' has"]
    assert read(steel(d1=0.1, d2=1.0)) == ["materials.m.damage.d3: missing (required)"]
    assert read(steel(**JC4340, spall_pressure=-1.0)) == [
        "materials.m.damage.spall_pressure: must be >= 0, got -1"]
    elastic = dict(model="elastic", density=1.0, E=1.0, nu=0.3,
                   damage=dict(model="johnson_cook", **JC4340))
    assert read(elastic)[0].startswith("materials.m.damage: unknown key")
    _, prm = catalog.pack(steel(**JC4340, spall_pressure=1e3))
    assert prm[L.DAMAGE] == L.DAMAGE_JOHNSON_COOK and prm[L.SPALL] == 1e3
    assert list(prm[[L.D1, L.D2, L.D3, L.D4, L.D5]]) == list(JC4340.values())


# ---------------------------------------------------------------- FEM elements

def test_a_hexahedron_accumulates_damage_and_fails_as_a_point_does():
    """One unit-cube element whose nodes move with v = L x (the mean gradient is exact
    for it): the element's damage follows the point's closed form to round-off of the
    gradient, and the element fails in the same step, losing deviator and tension."""
    from pmpm.fem.elements import VISCOUS, ElementMesh, Hourglass, element_forces
    from pmpm.kernels.records import BodyMaterials
    corners = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                        [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], np.float64)
    rate, dt = 10.0, 1e-3
    v = corners @ (rate * EXTENSION).T
    mesh = ElementMesh(corners, v, np.arange(8, dtype=np.int64)[None, :],
                       np.zeros(1, np.int32))
    code, prm = catalog.pack(steel(**JC4340))
    bodies = BodyMaterials(np.array([code], np.int64), prm[None, :], np.zeros(1, np.bool_))
    point = Point(steel(**JC4340), on_yield_surface(600.0, 600.0))
    state = MaterialState(point.mat.stress.copy(), *(a.copy() for a in point.mat[1:]))
    hourglass = Hourglass(np.array([VISCOUS], np.int64), np.zeros(1), np.zeros((1, 12)),
                          np.zeros(1))
    for _ in range(100):
        point.step(rate * EXTENSION, dt)
        _, bad, _ = element_forces(mesh, state, bodies, hourglass, dt, np.zeros((8, 3)))
        assert bad < 0
        assert state.damage[0] == pytest.approx(point.damage, rel=1e-9, abs=1e-12)
        if point.damage >= 1.0:
            break
    assert state.damage[0] == 1.0 and state.w_p[0] == pytest.approx(point.w_p, rel=1e-9)
    stress = state.stress[0]
    assert np.all(stress[3:] == 0.0) and np.all(stress[:3] == stress[0])
    assert -stress[:3].mean() == 0.0


def test_converted_elements_pass_their_damage_and_plastic_work_to_their_particles():
    """fem_taylor_convert.yaml's foot converted by hand: every particle carries the
    damage and the specific plastic work of the element it came from."""
    from runhelp import set_up
    from pmpm.solver.conversion import ID_STRIDE
    sim = set_up(os.path.join(HERE, "cases", "fem_taylor_convert.yaml"))
    fem = sim.elements
    fem.state.damage[:] = 1e-3 * fem.element_id
    fem.state.w_p[:] = 7.0 + fem.element_id
    low = fem.centroids()[:, 2] < 3.0
    fem.state.eps_p[low] = 1.0
    assert sim.conversion.transfer() == low.sum() > 0
    p = sim.particles
    element = (p.id - sim.conversion.id_base) // ID_STRIDE
    assert np.array_equal(p.damage, 1e-3 * element)
    assert np.array_equal(p.w_p, 7.0 + element)


# ---------------------------------------------------------------- runs and restarts

def history(out):
    from clihelp import read_history
    return read_history(out)


def last_frame(path, key, ids):
    with h5py.File(path) as f:
        frame = f["frames"][sorted(f["frames"], key=int)[-1]]
        order = np.argsort(frame[ids][...])
        return frame[key][...][order]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """damage_impact.yaml run whole, and cut at its first frame (3 us) then continued
    from the checkpoint (1 rank)."""
    from clihelp import run_ok
    whole = tmp_path_factory.mktemp("damage") / "whole"
    split = whole.parent / "split"
    run_ok([CASE, "--out", whole, "--quiet"])
    run_ok([CASE, "--out", split, "--quiet", "--set", "time.end=0.003", "--set",
            "output.frames=1"])
    run_ok([CASE, "--out", split, "--quiet", "--restart"])
    return whole, split


def test_an_impact_with_damage_reports_failed_points_and_plastic_work(runs):
    """Rod and plate fail in places; the failed count of summary.json is that of the
    frames (particles and elements); a plate element that fails turns into particles
    (fem.convert.failed, on by default), so the elements left are damaged but none
    failed, and the plate's failed points are its particles; each body's plastic work
    is in history.csv and summary.json, positive and at most its internal energy;
    ParaView finds `damage` in both time series."""
    whole, _ = runs
    summary = json.loads((whole / "summary.json").read_text())
    damage_p = last_frame(whole / "particles.h5", "damage", "id")
    damage_e = last_frame(whole / "elements.h5", "damage", "element_id")
    failed = int((damage_p >= 1).sum() + (damage_e >= 1).sum())
    assert summary["n_failed"] == failed
    assert all(summary["bodies"][b]["n_failed"] > 0 for b in ("rod", "plate"))
    assert 0 <= damage_p.min() and damage_p.max() == 1.0 and 0 < damage_e.max() < 1.0
    header, rows = history(whole)
    for body in ("rod", "plate"):
        plastic = rows[:, header.index(f"{body}.plastic")]
        internal = rows[:, header.index(f"{body}.internal")]
        energy = summary["bodies"][body]["energy"]
        assert plastic[0] == 0 and plastic[-1] == energy["plastic"] > 0
        # never decreases, but for the round-off of sums in a changing order
        assert np.all(np.diff(plastic) >= -1e-12 * plastic[-1])
        assert np.all(plastic <= internal)
    for name in ("particles.xdmf", "elements.xdmf"):
        assert 'Name="damage"' in (whole / name).read_text()


def test_damage_and_plastic_work_survive_a_restart(runs):
    """The run continued from its checkpoint ends bit for bit where the whole run does:
    the last history row (plastic work included), the damage of every particle and
    element, and the failed count."""
    whole, split = runs
    (header, one), (_, two) = history(whole), history(split)
    assert (one[-1] == two[-1]).all() and header[-2] == "rod.plastic"
    for name, ids in (("particles.h5", "id"), ("elements.h5", "element_id")):
        a, b = last_frame(whole / name, "damage", ids), last_frame(split / name, "damage", ids)
        assert np.array_equal(a, b) and a.max() > 0
    counts = [json.loads((d / "summary.json").read_text())["n_failed"] for d in runs]
    assert counts[0] == counts[1] > 0


def test_with_failed_false_a_failed_element_stays_an_element(tmp_path):
    """``fem.convert.failed: false``: plate elements reach damage 1 and stay elements
    (failed, carrying no deviator) until their plastic strain converts them; the failed
    count of summary.json counts them."""
    from clihelp import run_ok
    out = tmp_path / "kept"
    run_ok([CASE, "--out", out, "--quiet", "--set", "bodies[0].fem.convert.failed=false"])
    damage_e = last_frame(out / "elements.h5", "damage", "element_id")
    damage_p = last_frame(out / "particles.h5", "damage", "id")
    assert damage_e.max() == 1.0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_failed"] == int((damage_p >= 1).sum() + (damage_e >= 1).sum())
