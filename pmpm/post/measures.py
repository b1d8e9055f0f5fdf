"""Measures compared with the seeds: Taylor bar L and D, 1D wave-bar stress."""
import numpy as np


def taylor_length_and_diameter(x, spacing, axis=2, wall=0.0, foot_layer=None):
    """Final length L and foot diameter D of a Taylor bar standing on a wall.

    L is the top particle's distance from the wall plus half a particle spacing (the
    particle stands for a cube of that edge); D is twice the largest radial distance of a
    particle from the bar axis, plus one spacing (half a particle on either side). Both
    are measured from particle centres, so they carry an uncertainty of about half a
    spacing.
    """
    radial = [a for a in range(3) if a != axis]
    top = x[:, axis].max() - wall
    centre = np.average(x[:, radial], axis=0)
    r = np.linalg.norm(x[:, radial] - centre, axis=1)
    if foot_layer is not None:
        r = r[x[:, axis] - wall <= foot_layer]
    return top + 0.5 * spacing, 2.0 * r.max() + spacing


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


def rms_error(numerical, exact, scale):
    """Root mean square of (numerical - exact), divided by ``scale``."""
    diff = np.asarray(numerical) - np.asarray(exact)
    return float(np.sqrt(np.mean(diff ** 2)) / abs(scale))
