"""Reading FEM frames back (``DIR/elements.h5``, serial)."""
import os

import h5py
import numpy as np


def element_profiles(out_dir, times, axis=0, tol=1e-9):
    """{time: (centroid along ``axis``, sigma along ``axis``)} of every element, sorted
    along the axis, for the element frames at ``times``."""
    result = {}
    with h5py.File(os.path.join(out_dir, "elements.h5"), "r") as f:
        for name in f["frames"]:
            group = f["frames"][name]
            t = float(group.attrs["time"])
            for target in times:
                if abs(t - target) < tol:
                    x, s = group["centroid"][:, axis], group["stress"][:, axis]
                    order = np.argsort(x, kind="stable")
                    result[target] = (x[order], s[order])
    return result
