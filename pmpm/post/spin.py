"""Angular momentum of particle frames, with the affine (APIC) part, and the impulses of
an oblique impact (docs/validation/angular_momentum.md)."""
import numpy as np

from .frames import read_frame


def affine_spin(mass, affine, h):
    """sum_p m_p eps : B_p^T, the angular momentum the particles' affine matrices carry
    (B_p = h^2 A_p, with A_p the row-major ``affine`` column and h the cell edge)."""
    B = h * h * np.asarray(affine).reshape(-1, 3, 3)
    return np.stack([B[:, 2, 1] - B[:, 1, 2], B[:, 0, 2] - B[:, 2, 0],
                     B[:, 1, 0] - B[:, 0, 1]], axis=1).T @ mass


def spin_about_centroid(frame, h, body=None):
    """The angular momentum vector of a frame's particles (of ``body``, if given) about
    their centroid: orbital plus, under APIC, the affine part."""
    keep = slice(None) if body is None else frame["body"] == body
    m, x, v = frame["mass"][keep], frame["x"][keep], frame["v"][keep]
    r = x - m @ x / m.sum()
    L = np.cross(r, v).T @ m
    if "affine" in frame:
        L = L + affine_spin(m, frame["affine"][keep], h)
    return L


def oblique_impact(out, h, radius, body=0):
    """A sphere's oblique impact on a face z = const, from the first and last frames:
    the tangential (x) and normal (z) impulses, and the spin about y against the moment
    its tangential impulse implies (I omega = R |J_t| for a rigid sphere)."""
    first, last = read_frame(out, 0), read_frame(out)
    keep0, keep1 = first["body"] == body, last["body"] == body
    m = first["mass"][keep0]
    J = m @ last["v"][keep1] - m @ first["v"][keep0]
    spin = spin_about_centroid(last, h, body)[1]
    return {"J_t": float(-J[0]), "J_n": float(J[2]), "ratio": float(-J[0] / J[2]),
            "spin": float(spin), "spin_kept": float(spin / (radius * -J[0]))}
