"""Read frames of a run's particles.h5 (serially), sorted by particle id."""
import json
import os

import h5py
import numpy as np


def frame_times(out_dir):
    with h5py.File(os.path.join(out_dir, "particles.h5"), "r") as f:
        return [float(f["frames"][k].attrs["time"]) for k in sorted(f["frames"])]


def read_frame(out_dir, index=-1):
    """Columns of frame ``index`` (default the last) as a dict, rows sorted by id."""
    with h5py.File(os.path.join(out_dir, "particles.h5"), "r") as f:
        names = sorted(f["frames"])
        group = f["frames"][names[index]]
        data = {key: group[key][()] for key in group}
        data["time"] = float(group.attrs["time"])
    order = np.argsort(data["id"], kind="stable")
    return {k: (v[order] if isinstance(v, np.ndarray) and v.ndim and len(v) == len(order)
                else v) for k, v in data.items()}


def read_summary(out_dir):
    with open(os.path.join(out_dir, "summary.json"), encoding="utf-8") as f:
        return json.load(f)


def axial_profiles(out_dir, times, axis=0, tol=1e-9, volumes=False):
    """{time: (x_axis, sigma_axis)} sorted along ``axis`` for the frames at ``times``;
    with ``volumes``, {time: (x_axis, sigma_axis, particle volume)}."""
    result = {}
    with h5py.File(os.path.join(out_dir, "particles.h5"), "r") as f:
        for name in f["frames"]:
            group = f["frames"][name]
            t = float(group.attrs["time"])
            for target in times:
                if abs(t - target) < tol:
                    x, s = group["x"][:, axis], group["stress"][:, axis]
                    order = np.argsort(x, kind="stable")
                    result[target] = (x[order], s[order])
                    if volumes:
                        vol = group["mass"][:] / group["density"][:]
                        result[target] += (vol[order],)
    return result
