"""Quick-look pictures of a finished (or running) pmpm run, written as PNG with
matplotlib (``python -m pmpm.post RESULTS_DIR``): the energies and their balance, each
body's velocity and displacement, the contact and reaction forces, the probes, and a
frame as a projected scatter coloured by a field. Serial; reads history.csv,
forces.csv, probe_NAME.csv, particles.h5 and elements.h5 as they are on disk."""
import os

import h5py
import numpy as np

from .contact import BODY_FIELDS, body_names, read_history

#: Fields tried, in order, when none is asked for.
DEFAULT_FIELDS = ("von_mises", "eps_p", "density")
AXES = "xyz"


def pyplot():
    """matplotlib's pyplot on the file-only Agg backend (no display needed)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def plot_energies(out_dir, path):
    """Kinetic, internal and total energy against time, what contact and friction have
    dissipated (when measured), and the balance's change from the start (total +
    dissipated) as a share of the energy the run was given (the largest so far)."""
    hist = read_history(out_dir)
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    names = ["kinetic", "internal", "total"]
    dissipated = hist.get("dissipated")
    if dissipated is not None and np.all(np.isfinite(dissipated)) and dissipated.any():
        names.append("dissipated")
    else:
        dissipated = np.zeros_like(hist["total"])
    for name in names:
        top.plot(hist["time"], hist[name], label=name)
    top.set_ylabel("energy")
    top.legend()
    balance = hist["total"] + dissipated
    given = np.maximum.accumulate(np.abs(balance))
    drift = (balance - balance[0]) / np.where(given > 0, given, 1.0)
    bottom.plot(hist["time"], 100 * drift)
    bottom.set_ylabel("total + dissipated - start (% of the largest)")
    bottom.set_xlabel("time")
    fig.suptitle(os.path.basename(os.path.abspath(out_dir)) + ": energies")
    return _save(fig, path)


def plot_bodies(out_dir, path):
    """Each body's mass-weighted velocity components and centroid displacement."""
    hist = read_history(out_dir)
    names = body_names(hist)
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    for name in names:
        for k, axis in enumerate(AXES):
            v = hist[f"{name}.{BODY_FIELDS[3 + k]}"]
            x = hist[f"{name}.{BODY_FIELDS[k]}"]
            if np.ptp(v) > 0 or np.abs(v).max() > 0:
                top.plot(hist["time"], v, label=f"{name} v{axis}")
            if np.ptp(x) > 0:
                bottom.plot(hist["time"], x - x[0], label=f"{name} {axis}")
    return _finish(fig, (top, bottom), ("velocity", "centroid displacement"), out_dir,
                   ": bodies", path)


def read_csv(path):
    """A CSV of the run (forces.csv, probe_NAME.csv) as a numpy record array."""
    return np.genfromtxt(path, delimiter=",", names=True, deletechars="")


def plot_forces(out_dir, path):
    """forces.csv: each body pair's normal and tangential contact force (top) and each
    constrained face's and FEM support's force components that are not zero (bottom)."""
    forces = read_csv(os.path.join(out_dir, "forces.csv"))
    t = forces["time"]
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    for name in forces.dtype.names[2:]:
        values = forces[name]
        if not np.any(values):
            continue
        if "/" in name and name.endswith((".normal", ".tangential")):
            top.plot(t, values, label=name)
        elif "/" not in name:
            bottom.plot(t, values, label=name)
    return _finish(fig, (top, bottom), ("contact force", "reaction force"), out_dir,
                   ": forces (mean over each row)", path)


def plot_probes(out_dir, path, names):
    """Each probe's velocity components (top) and pressure and von Mises stress
    (bottom) against time."""
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    for name in names:
        probe = read_csv(os.path.join(out_dir, f"probe_{name}.csv"))
        for axis in AXES:
            if np.nanmax(np.abs(probe[f"v{axis}"]), initial=0.0) > 0:
                top.plot(probe["time"], probe[f"v{axis}"], label=f"{name} v{axis}")
        for field in ("pressure", "von_mises"):
            if not np.all(np.isnan(probe[field])):
                bottom.plot(probe["time"], probe[field], label=f"{name} {field}")
    return _finish(fig, (top, bottom), ("velocity", "stress"), out_dir, ": probes",
                   path)


def probe_names(out_dir):
    """The probes of a run, from its probe_NAME.csv files."""
    return sorted(f[len("probe_"):-len(".csv")] for f in os.listdir(out_dir)
                  if f.startswith("probe_") and f.endswith(".csv"))


def frame_points(out_dir, index, field):
    """(positions, values, time) of the particles of frame ``index`` and, with FEM
    bodies, the element centroids of the element frame at the same time."""
    with h5py.File(os.path.join(out_dir, "particles.h5"), "r") as f:
        names = sorted(f["frames"])
        group = f["frames"][names[index]]
        field = field or next((n for n in DEFAULT_FIELDS if n in group), None)
        if field not in group:
            raise KeyError(f"no field {field!r} in the frames; fields: {', '.join(sorted(group))}")
        x, value, time = group["x"][()], _scalar(group[field][()]), float(group.attrs["time"])
    elements = os.path.join(out_dir, "elements.h5")
    if os.path.exists(elements):
        with h5py.File(elements, "r") as f:
            for group in f["frames"].values():
                if abs(float(group.attrs["time"]) - time) <= 1e-9 * max(abs(time), 1e-30) \
                        and field in group:
                    x = np.concatenate([x, group["centroid"][()]])
                    value = np.concatenate([value, _scalar(group[field][()])])
    return x, value, time, field


def plot_frame(out_dir, path, index=-1, field=None, normal="y"):
    """Frame ``index`` seen along ``normal``: every point projected on the other two
    axes, drawn back to front, coloured by ``field`` (its magnitude for a vector)."""
    x, value, time, field = frame_points(out_dir, index, field)
    drop = AXES.index(normal)
    keep = [a for a in range(3) if a != drop]
    order = np.argsort(x[:, drop])
    plt = pyplot()
    fig, axes = plt.subplots(figsize=(7, 6))
    size = float(np.clip(2e4 / max(len(x), 1), 1.0, 20.0))      # dots that tile the view
    art = axes.scatter(x[order, keep[0]], x[order, keep[1]], c=value[order], s=size,
                       cmap="viridis", linewidths=0)
    fig.colorbar(art, ax=axes, label=field)
    axes.set_aspect("equal")
    axes.set_xlabel(AXES[keep[0]])
    axes.set_ylabel(AXES[keep[1]])
    axes.set_title(f"{os.path.basename(os.path.abspath(out_dir))}: {field} at t = {time:.4g}")
    return _save(fig, path)


def _finish(fig, panels, labels, out_dir, title, path):
    """Label a two-panel time plot, add the legends of panels that drew lines, title it
    with the run's folder name and save it."""
    for axes, label in zip(panels, labels):
        axes.set_ylabel(label)
        if axes.lines:
            axes.legend(fontsize="small")
    panels[-1].set_xlabel("time")
    fig.suptitle(os.path.basename(os.path.abspath(out_dir)) + title)
    return _save(fig, path)


def _scalar(values):
    return values if values.ndim == 1 else np.linalg.norm(values, axis=1)


def _save(fig, path):
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt
    plt.close(fig)
    return path
