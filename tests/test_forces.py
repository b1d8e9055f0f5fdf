"""Force histories (forces.csv, issue 26): contact forces per body pair and reactions of
grid faces and FEM supports, checked against closed forms: a force integrated over the
run is the momentum it gave (to round-off, whatever the coupling), a block resting on a
floor presses with its weight, a sliding block's friction is mu times its normal force,
and a striker's contact force is rho c v0 A / 2 (1D impact). 1 rank = 2 ranks; a restart
continues the file."""
import json
import os

import numpy as np
import pytest

from clihelp import BAR, BAR_HALF_END, CASES, run_ok

TWO_BARS = os.path.join(CASES, "two_bars.yaml")
STRIKER_FEM = os.path.join(CASES, "striker_on_fem_bar.yaml")
BLOCK_PLATE = os.path.join(CASES, "block_on_fem_plate.yaml")
CANTILEVER = os.path.join(CASES, "obstacle_cantilever.yaml")


def read(out, name):
    return np.genfromtxt(os.path.join(out, name), delimiter=",", names=True,
                         deletechars="")


def masses(out):
    with open(os.path.join(out, "summary.json"), encoding="utf-8") as f:
        return {k: b["mass"] for k, b in json.load(f)["bodies"].items()}


def impulse(forces, column):
    """A mean-force column integrated over the run (each row: the mean since the last)."""
    return float((forces[column][1:] * np.diff(forces["time"])).sum())


def momentum_change(out, body, axis):
    h = read(out, "history.csv")
    return masses(out)[body] * (h[f"{body}.v{axis}"][-1] - h[f"{body}.v{axis}"][0])


@pytest.fixture(scope="module")
def bars(tmp_path_factory):
    """Two elastic bars end on, grid contact (method 2, release rule), 1 and 2 ranks."""
    base = tmp_path_factory.mktemp("forces_bars")
    outs = {n: base / f"r{n}" for n in (1, 2)}
    for n, out in outs.items():
        run_ok([TWO_BARS, "--out", out, "--quiet", "--set", "output.history_every=1",
                "--set", "time.end=0.012"], n)
    return outs


def test_grid_contact_impulse_is_the_strikers_momentum_change(bars):
    f = read(bars[1], "forces.csv")
    for axis in "xyz":
        dp = momentum_change(bars[1], "striker", axis)
        assert impulse(f, f"striker/bar.f{axis}") == pytest.approx(dp, rel=1e-9, abs=1e-15)
    assert momentum_change(bars[1], "striker", "x") < -0.9 * 0.125   # it has stopped


def test_the_1d_contact_force_is_rho_c_v0_a_over_2(bars):
    """Over the pulse (2 Ls / c) the mean normal force is the 1D impact's."""
    f = read(bars[1], "forces.csv")
    rho, c, v0, area, ls = 5e-3, np.sqrt(1e5 / 5e-3), 10.0, 0.25, 10.0
    pulse = f["time"] <= 2 * ls / c
    mean = impulse(f[pulse], "striker/bar.normal") / f["time"][pulse][-1]
    assert mean == pytest.approx(rho * c * v0 / 2 * area, rel=0.03)
    assert np.allclose(f["striker/bar.fx"], -f["striker/bar.normal"], atol=1e-9)
    assert np.all(f["striker/bar.tangential"] == 0.0)


def test_frictionless_contact_dissipates_nothing(bars):
    """Grid contact leaves the bars moving together along the normal: its impulses do
    no work against the motion they leave (measured 6e-18 of the striker's energy; the
    balance itself loses 1.7 %, numerically)."""
    h, f = read(bars[1], "history.csv"), read(bars[1], "forces.csv")
    assert np.abs(h["dissipated"]).max() < 1e-12 * h["kinetic"][0]
    columns = [c for c in f.dtype.names if c.endswith(".dissipated")]
    assert "striker/bar.dissipated" in columns
    assert np.allclose(sum(f[c] for c in columns), h["dissipated"], rtol=1e-12, atol=0)


def test_two_ranks_give_the_one_rank_forces(bars):
    one, two = read(bars[1], "forces.csv"), read(bars[2], "forces.csv")
    assert one.dtype.names == two.dtype.names and len(one) == len(two)
    for name in one.dtype.names:
        assert np.allclose(one[name], two[name], rtol=1e-9, atol=1e-9, equal_nan=True), name


def test_surface_contact_impulse_is_the_strikers_momentum_change(tmp_path):
    run_ok([STRIKER_FEM, "--out", tmp_path, "--quiet", "--set", "output.history_every=1",
            "--set", "time.end=0.01"])
    f = read(tmp_path, "forces.csv")
    dp = momentum_change(tmp_path, "striker", "x")
    assert dp < -0.02
    assert impulse(f, "striker/bar.fx") == pytest.approx(dp, rel=1e-9)


def test_a_sliding_block_rubs_with_mu_times_its_normal_force(tmp_path):
    """A block sliding on an FEM plate lying on the fixed floor: the friction is mu times
    the normal force (Coulomb, row by row), the block's momentum change is the contact
    impulse plus its weight's, and the floor carries the weight of both."""
    run_ok([BLOCK_PLATE, "--out", tmp_path, "--quiet", "--set", "params.g=9.81",
            "--set", "params.gap=0", "--set", "params.z_floor=0", "--set", "params.vz=0",
            "--set", "output.history_every=20"])
    f, m = read(tmp_path, "forces.csv"), masses(tmp_path)
    pressing = f["plate/block.normal"] > 0
    assert pressing.sum() > 0.8 * len(f)
    assert np.allclose(f["plate/block.tangential"][pressing],
                       0.3 * f["plate/block.normal"][pressing], rtol=1e-3)
    end = f["time"][-1]
    for axis, weight in (("x", 0.0), ("z", -9.81 * m["block"] * end)):
        dp = momentum_change(tmp_path, "block", axis)
        # round-off relative to the terms summed: the weight's impulse and the contact's
        # nearly cancel since the contact on the block's grid (issue 24 Sec. 4) holds the
        # block up (dp_z -1.4e-3 of a weight impulse 7.5e-2; -1.4e-2 before), and the
        # grid route adds its round-off (measured 2e-12 apart, 1e-12 before)
        assert -impulse(f, f"plate/block.f{axis}") + weight == pytest.approx(
            dp, rel=1e-9, abs=1e-9 * (abs(weight) + abs(dp)))
    floor = impulse(f, "z-.fz") / end
    assert floor == pytest.approx(9.81 * (m["block"] + m["plate"]), rel=0.03)
    surface_friction_work_closes_the_balance(tmp_path, m)


def surface_friction_work_closes_the_balance(out, m):
    """The friction of the surface pairs is the only horizontal force on the block: its
    work (history.csv's dissipated) is the block's loss of horizontal kinetic energy
    within 3 % (measured -1.9 %, the rest goes to the plate); with it kinetic + internal
    + dissipated - the work of gravity keeps within 0.5 % of the energy given (measured
    0.008 %; 14 % goes unaccounted without it)."""
    h = read(out, "history.csv")
    lost = 0.5 * m["block"] * (h["block.vx"][0] ** 2 - h["block.vx"][-1] ** 2)
    assert h["dissipated"][-1] == pytest.approx(lost, rel=0.03)
    fell = sum(m[b] * (h[f"{b}.z"] - h[f"{b}.z"][0]) for b in ("plate", "block"))
    balance = h["total"] + h["dissipated"] + 9.81 * fell
    assert np.abs(balance - balance[0]).max() < 0.005 * h["total"][0]


def test_a_resting_bar_presses_on_the_floor_with_its_weight(tmp_path):
    """The copper bar of cli_bar at rest on a fixed floor under gravity: the floor's mean
    reaction over about 30 periods of the bar's axial vibration is its weight."""
    g = 9.81e-3
    run_ok([BAR, "--out", tmp_path, "--quiet", "--set", "params.v0=0",
            "--set", f"gravity=[0, 0, {-g}]", "--set", "grid.boundary.z-=fixed",
            "--set", "time.end=0.2", "--set", "output.history_every=20",
            "--set", "output.times=[]", "--set", "output.checkpoints=false"])
    f, end = read(tmp_path, "forces.csv"), 0.2
    weight = g * masses(tmp_path)["bar"]
    dp = momentum_change(tmp_path, "bar", "z")
    assert impulse(f, "z-.fz") - weight * end == pytest.approx(dp, abs=1e-8 * weight * end)
    assert impulse(f, "z-.fz") / end == pytest.approx(weight, rel=0.02)


def test_wall_impact_and_fem_supports_close_the_momentum_balance(tmp_path):
    """The bar hitting a slip wall (the wall's impulse is its momentum change) and a
    clamped FEM cantilever under a body force (supports and faces balance it)."""
    run_ok([BAR, "--out", tmp_path / "bar", "--quiet", "--set", "output.history_every=1"])
    f = read(tmp_path / "bar", "forces.csv")
    assert f.dtype.names == ("step", "time", "z-.fx", "z-.fy", "z-.fz", "z-.dissipated")
    kinetic = read(tmp_path / "bar", "history.csv")["kinetic"][0]
    assert np.abs(f["z-.dissipated"]).max() < 1e-9 * kinetic      # a slip wall
    dp = momentum_change(tmp_path / "bar", "bar", "z")
    assert dp > 0.0 and impulse(f, "z-.fz") == pytest.approx(dp, rel=1e-9)
    out = tmp_path / "cantilever"
    run_ok([CANTILEVER, "--out", out, "--quiet", "--set", "time.end=40",
            "--set", "output.history_every=5", "--set", "output.frames=1"])
    f, m = read(out, "forces.csv"), masses(out)["obstacle"]
    assert "obstacle.support.fx" in f.dtype.names
    for axis, body_force in zip("xyz", (0.01 * m * 40.0, 0.0, 0.0)):
        total = sum(impulse(f, c) for c in f.dtype.names if c.endswith(f".f{axis}"))
        dp = momentum_change(out, "obstacle", axis)
        assert total + body_force == pytest.approx(dp, rel=1e-9, abs=1e-12)
    assert impulse(f, "obstacle.support.fx") < 0.0       # the clamp holds it back


def test_a_restart_continues_forces_csv(tmp_path):
    full, cut = tmp_path / "full", tmp_path / "cut"
    run_ok([BAR, "--out", full, "--quiet"])
    run_ok([BAR, "--out", cut, "--quiet", "--set", f"time.end={BAR_HALF_END}"])
    run_ok([BAR, "--out", cut, "--quiet", "--restart"])
    a, b = read(full, "forces.csv"), read(cut, "forces.csv")
    assert len(a) == len(b)
    for name in a.dtype.names:
        assert np.array_equal(a[name], b[name]), name


def test_forces_false_writes_no_file(tmp_path):
    run_ok([BAR, "--out", tmp_path, "--quiet", "--set", "output.forces=false"])
    assert not os.path.exists(os.path.join(tmp_path, "forces.csv"))
