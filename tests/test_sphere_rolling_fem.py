"""The sphere of seed 004 Sec. 4.1 rolling on an FEM plate by surface contact (ICFEMP),
shortened: runs/sphere_rolling_fem.yaml at full resolution (0.2 m cells, 0.1 m spacing),
R = 4 (0.8 m elements), mu = 0.4, to t = 0.6 s (the sweep to 2 s is
scripts/sphere_rolling_fem.py: +2.4 % at R = 4, +2.6 % at R = 8 against Eq. 55)."""
import math
import os

from clihelp import pmpm, read_history

CASE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "runs",
                    "sphere_rolling_fem.yaml")


def test_the_sphere_rolls_down_the_fem_plate_near_eq_55(tmp_path):
    """Eq. 55 (rolling): x = (5/14) g t^2 sin(theta). The elastic sphere slips at first,
    before its shear builds up (x is 40 % ahead at 0.1 s), then rolls: at 0.6 s it is
    8.0 % ahead (measured), by 2 s 2.4 %. Tolerance: between 0 and +15 % at 0.6 s (frictionless
    sliding would be +40 %); the sphere stays on the plate: its centre no more than
    0.3 m lower than at the start (the soft sphere flattens, measured 0.17 m) and never
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
    assert 1.0 < x[-1] / exact < 1.15
    assert z.min() > 3200.0 - 300.0 and z.max() <= 3200.0 + 1e-9
