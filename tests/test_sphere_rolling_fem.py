"""The sphere of seed 004 Sec. 4.1 rolling on an FEM plate by surface contact (ICFEMP),
shortened: runs/sphere_rolling_fem.yaml at full resolution (0.2 m cells, 0.1 m spacing),
R = 4 (0.8 m elements), mu = 0.4, to t = 0.6 s (the sweep to 2 s is
scripts/sphere_rolling_fem.py: -0.9 % at R = 4, -0.8 to -1.2 % over R = 1-8 against
Eq. 55)."""
import math
import os

from clihelp import pmpm, read_history

CASE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "runs",
                    "sphere_rolling_fem.yaml")


def test_the_sphere_rolls_down_the_fem_plate_near_eq_55(tmp_path):
    """Eq. 55 (rolling): x = (5/14) g t^2 sin(theta). At 0.6 s the sphere is 1.2 % ahead
    (measured; 8.0 % before the particle side of surface contact met the faces on its
    grid, when the sphere sank 0.17 m into the plate and slipped before it rolled), by
    2 s 0.9 % behind. Tolerance: within 4 % at 0.6 s (the seed's ICFEMP: 5-6 % at 2 s;
    frictionless sliding would be +40 %); the sphere stays on the plate: its centre no
    more than 0.1 m lower than at the start (the soft sphere flattens) and never
    higher."""
    out = tmp_path / "out"
    done = pmpm([CASE, "--out", out, "--quiet", "--set", "params.R=4", "--set",
                 "time.end=600", "--set", "output.history_every=5"], timeout=300)
    assert done.returncode == 0, done.stderr
    header, rows = read_history(out)
    t = rows[:, header.index("time")] / 1000.0                 # s
    x = (rows[:, header.index("sphere.x")] - 2000.0) / 1000.0  # m
    z = rows[:, header.index("sphere.z")]
    g_sin = 10.0 * math.sin(math.pi / 4)
    exact = 5.0 / 14.0 * g_sin * t[-1] ** 2
    assert t[-1] == 0.6
    print(f"x = {x[-1]:.4f} m, Eq. 55 {exact:.4f} m, z {z.min():.1f} .. {z.max():.1f}")
    assert abs(x[-1] / exact - 1.0) < 0.04
    assert z.min() > 3200.0 - 100.0 and z.max() <= 3200.0 + 1e-9
