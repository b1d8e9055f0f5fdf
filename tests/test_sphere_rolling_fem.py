"""The sphere of seed 004 Sec. 4.1 rolling on an FEM plate by surface contact (ICFEMP),
shortened: runs/sphere_rolling_fem.yaml at full resolution (0.2 m cells, 0.1 m spacing)
to t = 0.6 s, the plate's elements 2 and 8 cells wide (R), rolling (mu 0.4) and sliding
(mu 0.2), and the grid coupling (CFEMP) rolling at R = 1 and 4. The sweep to 2 s is
scripts/sphere_rolling_fem.py: ICFEMP -0.8 to -1.2 % (rolling) and -0.2 to +0.1 %
(sliding) over R = 1-8 against Eq. 55."""
import math
import os

import pytest

from clihelp import pmpm, read_history

CASE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "runs",
                    "sphere_rolling_fem.yaml")
END = 0.6          # s
RS, MUS = (2, 8), (0.4, 0.2)


def exact_travel(mu, t):
    """The rigid sphere on the incline at pi/4 under 10 m/s^2 (m): Eq. 55, rolling
    (5/14) g sin t^2 where mu >= (2/7) tan theta, else sliding (1/2) g (sin - mu cos) t^2."""
    g_sin = g_cos = 10.0 * math.sin(math.pi / 4)
    if mu >= 2.0 / 7.0:
        return 5.0 / 14.0 * g_sin * t ** 2
    return 0.5 * (g_sin - mu * g_cos) * t ** 2


@pytest.fixture(scope="module")
def travels(tmp_path_factory):
    """(R, mu) -> (travel at END in m, lowest and highest centre z in mm)."""
    found = {}
    for r in RS:
        for mu in MUS:
            out = tmp_path_factory.mktemp(f"roll_R{r}_mu{mu}")
            done = pmpm([CASE, "--out", out, "--quiet", "--set", f"params.R={r}", "--set",
                         f"params.mu={mu}", "--set", f"time.end={1000 * END}", "--set",
                         "output.history_every=5", "--set", "output.frames=1"], timeout=300)
            assert done.returncode == 0, done.stderr
            header, rows = read_history(out)
            assert rows[-1, header.index("time")] == 1000 * END
            z = rows[:, header.index("sphere.z")]
            found[r, mu] = ((rows[-1, header.index("sphere.x")] - 2000.0) / 1000.0,
                            z.min(), z.max())
    return found


@pytest.mark.parametrize("mu", MUS)
@pytest.mark.parametrize("r", RS)
def test_the_sphere_travels_near_eq_55_and_stays_on_the_plate(travels, r, mu):
    """Within 4 % of Eq. 55 at 0.6 s (measured +2.0 / +1.3 % at R = 2, +1.3 / +0.9 % at
    R = 8, rolling / sliding; the seed's ICFEMP: 5-6 % at 2 s; frictionless sliding
    would be +40 % on the rolling sphere); the sphere stays on the plate: its centre no
    more than 0.1 m lower than at the start (the soft sphere flattens: 47-53 mm
    measured) and never more than 10 mm higher (a twentieth of a cell; measured 3.6 mm
    at R = 8 rolling, 0 in the others)."""
    x, z_low, z_high = travels[r, mu]
    print(f"R {r}, mu {mu}: x = {x:.4f} m, Eq. 55 {exact_travel(mu, END):.4f} m")
    assert abs(x / exact_travel(mu, END) - 1.0) < 0.04
    assert z_low > 3200.0 - 100.0 and z_high < 3200.0 + 10.0


@pytest.mark.parametrize("mu", MUS)
def test_the_travel_does_not_depend_on_the_plate_elements(travels, mu):
    """Seed 004 Table 1: ICFEMP's travel is the same whatever the plate's elements are
    against the cells (its column: 10.7 m rolling and 11.8-11.9 m sliding for R = 1-8),
    where CFEMP's goes wrong as the elements grow. Elements 2 and 8 cells wide move the
    travel at 0.6 s by at most 1.5 % of Eq. 55's (measured 0.65 % rolling, 0.45 %
    sliding; 0.4 % and 0.3 % over R = 1-8 at 2 s)."""
    spread = abs(travels[RS[0], mu][0] - travels[RS[1], mu][0])
    assert spread < 0.015 * exact_travel(mu, END)


#: CFEMP, the grid coupling, as scripts/sphere_rolling_fem.py --coupling grid runs it,
#: with Ma et al.'s detection (contact.separation), as the seed's CFEMP runs it
CFEMP = ["contact.coupling=grid", "params.method=1", "grid.shape_functions=gimp",
         "contact.pairs=[{bodies: [plate, sphere], normal: plate}]",
         "contact.separation=0.9"]


def rolled(tmp_path, r, sets):
    out = tmp_path / f"R{r}"
    args = [CASE, "--out", out, "--quiet", "--set", f"params.R={r}", "--set", "params.mu=0.4",
            "--set", f"time.end={1000 * END}", "--set", "output.frames=1"]
    done = pmpm(args + [a for s in sets for a in ("--set", s)], timeout=300)
    assert done.returncode == 0, done.stderr
    header, rows = read_history(out)
    return (rows[-1, header.index("sphere.x")] - 2000.0) / 1000.0


def test_cfemp_rolls_near_eq_55_only_where_the_elements_are_the_cells(tmp_path):
    """Seed 004 Table 1's CFEMP column: the rolling sphere near Eq. 55 with elements one
    cell wide (10.2 m at 2 s, +1 %) and far from it with elements four cells wide (9.0 m,
    -11 %): the grid coupling needs the FE nodes as dense as the grid's. At 0.6 s pmpm
    gives -4.3 % at R = 1 and -14.6 % at R = 4 (-10.4 % and -17.8 % without Ma et al.'s
    detection; ICFEMP +1.3 to +2.0 % at every R, above). Tolerances: within 6 % at R = 1,
    more than 10 % short at R = 4."""
    exact = exact_travel(0.4, END)
    near, coarse = (rolled(tmp_path, r, CFEMP) / exact - 1.0 for r in (1, 4))
    print(f"CFEMP at 0.6 s: R = 1 {near:+.2%}, R = 4 {coarse:+.2%}")
    assert abs(near) < 0.06
    assert coarse < -0.10
