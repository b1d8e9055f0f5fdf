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
