"""Measures compared with the seeds: Taylor bar L and D, 1D wave-bar stress."""
import numpy as np


def taylor_length_and_diameter(x, axis=2, wall=0.0):
    """Final length L and foot diameter D of a Taylor bar standing on a wall, measured
    from particle centres: L is the highest centre's distance from the wall, D twice the
    largest distance of a centre from the bar's axis (through the mean of the centres).

    A particle stands for a cube of about one spacing, so the body's surface lies up to
    half a spacing beyond the outermost centres: that is the measurement uncertainty.
    """
    radial = [a for a in range(3) if a != axis]
    centre = np.mean(x[:, radial], axis=0)
    r = np.linalg.norm(x[:, radial] - centre, axis=1)
    return float(x[:, axis].max() - wall), float(2.0 * r.max())


def taylor_shape(x, axis=2, wall=0.0):
    """``{"L", "D", "D_widest"}`` of a Taylor bar: the length and widest-centre diameter
    of :func:`taylor_length_and_diameter`, D the footprint's :func:`foot_diameter`."""
    length, widest = taylor_length_and_diameter(x, axis, wall)
    return {"L": length, "D": foot_diameter(x, axis), "D_widest": widest}


def foot_diameter(x, axis=2):
    """The equivalent-circle diameter of a Taylor bar's footprint: ``2 sqrt(A / pi)`` with
    A the area of the convex hull of the particle centres projected along ``axis``.

    On a coarse grid the foot spreads further along the grid axes than between them (at
    0.76 mm cells the largest centre radius of the final bar differs by 8 % between
    directions), so the widest centre (:func:`taylor_length_and_diameter`) depends on a
    few particles, while the footprint's area does not. Like the widest centre, the hull
    lies up to half a particle spacing inside the body's surface."""
    radial = [a for a in range(3) if a != axis]
    return float(2.0 * np.sqrt(convex_hull_area(x[:, radial]) / np.pi))


def convex_hull_area(points):
    """Area of the convex hull of 2D ``points`` (n, 2), by the monotone chain."""
    p = np.unique(np.asarray(points, dtype=np.float64), axis=0)
    if len(p) < 3:
        return 0.0
    p = p[np.lexsort((p[:, 1], p[:, 0]))]

    def chain(pts):
        hull = []
        for q in pts:
            while len(hull) >= 2 and _turn(hull[-2], hull[-1], q) <= 0.0:
                hull.pop()
            hull.append(q)
        return hull[:-1]

    hull = np.array(chain(p) + chain(p[::-1]))
    x, y = hull[:, 0], hull[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _turn(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def wave_bar_stress(x, t, length, c, load_stress):
    """1D axial stress at positions ``x`` and time ``t`` in a bar fixed at x = 0 and
    loaded by a step stress ``load_stress`` at x = length (before the second reflection
    at the loaded end, t < 2 length / c)."""
    front = length - c * t                      # incident front, travelling to -x
    stress = np.where(x >= front, load_stress, 0.0)
    if c * t > length:                          # reflected from the fixed end: doubles
        reflected = c * t - length
        stress = np.where(x <= reflected, 2.0 * load_stress, stress)
    return stress


def rms_error(numerical, exact, scale, weights=None):
    """Root mean square of (numerical - exact), divided by ``scale``. With ``weights``
    (particle volumes, say) the mean is weighted: on a grid with refined windows, whose
    particles are smaller, this is the RMS along the bar rather than over particles."""
    diff = np.asarray(numerical) - np.asarray(exact)
    return float(np.sqrt(np.average(diff ** 2, weights=weights)) / abs(scale))
