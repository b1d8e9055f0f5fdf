"""Planar impact of copper on copper at 1000 m/s in uniaxial strain (issue 14) against the
Rankine-Hugoniot jump with copper's Us = c0 + s up line: shock speed, pressure, density
and particle velocity behind each shock, and the total energy. The coarse case
(tests/cases/planar_shock.yaml) runs 0.25 us with 1.5 mm bodies; the full case and the
figures are in runs/planar_shock.yaml and docs/validation/planar_shock.md.

In the symmetric frame (flyer +500, target -500 m/s) the shocked copper is at rest on the
grid and pmpm matches the jump. With the target at rest the shocked copper moves across
the cells at 20 GPa and USF gains energy at every cell crossing (linear shape functions:
not in the EOS, the bulk viscosity or the energy equation); that test is an expected
failure until shape functions whose gradients are continuous across cells cure it."""
import os

import numpy as np
import pytest

from pmpm.post import read_summary
from pmpm.post.shock import planar_shock_errors, rankine_hugoniot
from runhelp import CASES, run_pmpm

CASE = os.path.join(CASES, "planar_shock.yaml")
RHO0, C0, S = 8.93e-3, 3940.0, 1.49
MEASURES = ("Us", "P", "rho", "up")
#: largest relative errors on the plateau behind each shock at 0.25 us, when about 1 mm
#: of each body is shocked (20 particle layers; the plateau is the middle half of them):
#: measured -0.4/-4.6/-0.5/-0.9 % (MUSL, cfl 0.5) and -0.4/-3.1/-0.3/-0.3 % (USF, cfl
#: 0.1); the pressure carries the start-up transient at the impact face (7 % gives room)
TOLERANCE = {"Us": 0.02, "P": 0.07, "rho": 0.015, "up": 0.03}
ENERGY = 0.025        # |growth| of the total energy; measured +1.7 % and +0.4 %


def run(tmp_path, v_flyer, scheme, cfl):
    out = tmp_path / "out"
    run_pmpm(CASE, out, sets=[f"params.v_flyer={v_flyer}", f"time.scheme={scheme}",
                              f"time.cfl={cfl}"])
    measured = planar_shock_errors(str(out), v_flyer, v_flyer - 1000.0, RHO0, C0, S)
    return measured, read_summary(str(out))["energy_balance"]


def test_the_exact_answer():
    """The jump of a symmetric copper impact at 1000 m/s, worked by hand: up = 500 m/s,
    Us = 3940 + 1.49 * 500 = 4685 m/s, P = 8930 kg/m^3 * 4685 * 500 = 20.92 GPa."""
    exact = rankine_hugoniot(1000.0, RHO0, C0, S)
    assert exact["up"] == 500.0 and exact["Us"] == pytest.approx(4685.0, rel=1e-12)
    assert exact["P"] == pytest.approx(20917.0, rel=1e-4)          # MPa
    assert exact["rho"] / RHO0 == pytest.approx(1.11947, rel=1e-5)
    # energy jump = the Rayleigh line's area P (1/rho0 - 1/rho)/2
    assert exact["de"] == pytest.approx(0.5 * exact["P"] * (1 / RHO0 - 1 / exact["rho"]),
                                        rel=1e-12)


@pytest.mark.parametrize("scheme, cfl", [("musl", 0.5), ("usf", 0.1)])
def test_symmetric_impact_matches_rankine_hugoniot(tmp_path, scheme, cfl):
    measured, balance = run(tmp_path, 500.0, scheme, cfl)
    for body in ("flyer", "target"):
        errors = measured["errors"][body]
        for key in MEASURES:
            assert abs(errors[key]) < TOLERANCE[key], (body, key, errors)
    # the two shocks mirror each other
    np.testing.assert_allclose(measured["flyer"]["p"], measured["target"]["p"], rtol=1e-9)
    assert abs(balance["growth"]) < ENERGY and balance["largest_growth"] < ENERGY


#: target at rest, USF cfl 0.5, measured (flyer / target): bspline Us 0.0/+0.1 %, P -3.7/
#: -3.3 %, rho -0.3/-0.3 %, up -3.6/-3.4 % (the wider B-spline smears the plateau),
#: energy +1.1 %; linear hats: energy +18 %, target P +17 %, Us +8 %
AT_REST = {**TOLERANCE, "up": 0.04}


@pytest.mark.parametrize("shape", [
    "bspline",
    pytest.param("linear", marks=pytest.mark.xfail(
        strict=True, reason="issue 14: shocked copper moving across cells gains energy "
                            "under USF with linear shape functions (+18 % in 0.25 us here, "
                            "target pressure +17 %); docs/validation/planar_shock.md"))])
def test_impact_on_a_target_at_rest_matches_rankine_hugoniot(tmp_path, shape):
    """The same impact seen from the target: the jump is Galilean invariant, and so is
    pmpm's answer with shape functions whose gradients are continuous across cells."""
    out = tmp_path / "out"
    run_pmpm(CASE, out, sets=["params.v_flyer=1000", "time.scheme=usf", "time.cfl=0.5",
                              f"grid.shape_functions={shape}"])
    measured = planar_shock_errors(str(out), 1000.0, 0.0, RHO0, C0, S)
    balance = read_summary(str(out))["energy_balance"]
    assert abs(balance["growth"]) < ENERGY
    for body in ("flyer", "target"):
        errors = measured["errors"][body]
        for key in MEASURES:
            assert abs(errors[key]) < AT_REST[key], (body, key, errors)


#: (rho0 g/mm^3, c0 m/s, s, gamma0): copper, and 6061 aluminium (Steinberg's table)
MATERIALS = {"copper": (8.93e-3, 3940.0, 1.49, 2.0), "aluminium": (2.703e-3, 5240.0, 1.4, 1.97)}
#: issue 14: shock speed, pressure, density and particle velocity within 3 %, total
#: energy within 2 %. Measured at the defaults (gimp, USF, cfl 0.5; flyer / target): the
#: largest error is Us -2.6 % (copper, 100 m/s, the weak shock's front is smeared over
#: the most cells); energy +1.5 % at most (aluminium, 1000 m/s)
AT_DEFAULTS, ENERGY_AT_DEFAULTS = 0.03, 0.02


def defaults():
    """``--set`` items that spell out the schema's defaults of ``time.scheme``,
    ``time.cfl`` and ``grid.shape_functions``: the case file names its own, the test
    must run pmpm's."""
    from pmpm.case.schema import GRID, TIME
    return [f"time.scheme={TIME['scheme'].default}", f"time.cfl={TIME['cfl'].default}",
            f"grid.shape_functions={GRID['shape_functions'].default}"]


@pytest.mark.parametrize("material", sorted(MATERIALS))
@pytest.mark.parametrize("speed", [100.0, 500.0, 1000.0])
def test_impacts_at_the_defaults_match_rankine_hugoniot(tmp_path, material, speed):
    """A flyer on a target at rest at 100, 500 and 1000 m/s in two materials, at pmpm's
    default update order, shape functions and cfl: every jump quantity within 3 % on
    both sides and the total energy within 2 % (8 frames for the front's speed)."""
    rho0, c0, s, gamma0 = MATERIALS[material]
    out = tmp_path / "out"
    run_pmpm(CASE, out, sets=[f"params.v_flyer={speed}", f"params.v_rel={speed}",
                              f"params.rho0={rho0}", f"params.c0={c0}", f"params.s={s}",
                              f"params.gamma0={gamma0}", "output.frames=8", *defaults()])
    measured = planar_shock_errors(str(out), speed, 0.0, rho0, c0, s)
    balance = read_summary(str(out))["energy_balance"]
    assert abs(balance["growth"]) < ENERGY_AT_DEFAULTS
    assert balance["largest_growth"] < ENERGY_AT_DEFAULTS
    for body in ("flyer", "target"):
        errors = measured["errors"][body]
        assert all(abs(errors[key]) < AT_DEFAULTS for key in MEASURES), (body, errors)
