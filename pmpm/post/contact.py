"""Measures of the contact validation cases (seed 001 Sec. 5): per-body histories,
residual velocity, the rings' energy steps, the rolling sphere's travel (Eq. 36), and
the hole and height of a perforated plate. Serial, numpy only.

Particle positions are particle centres: a particle stands for a cube of one spacing d,
so a body's surface lies up to d/2 beyond its outermost centres. The functions below say
where they add that half spacing.
"""
import csv
import os

import h5py
import numpy as np

BODY_FIELDS = ("x", "y", "z", "vx", "vy", "vz")


# ---------------------------------------------------------------- history.csv

def read_history(out_dir):
    """Columns of ``out_dir/history.csv`` as ``{name: float array}``, the header's names
    kept as written (``time``, ``total``, ``ball.vz``, ...)."""
    path = os.path.join(out_dir, "history.csv")
    with open(path, encoding="utf-8", newline="") as handle:
        rows = list(csv.reader(handle))
    header, body = rows[0], [r for r in rows[1:] if r]
    data = np.array(body, dtype=float).reshape(len(body), len(header))
    return {name: data[:, i] for i, name in enumerate(header)}


def body_names(hist):
    """Body names in the order of the history's columns."""
    return [key[:-2] for key in hist if key.endswith(".x")]


def body_history(hist, name):
    """``{"time": (n,), "centroid": (n, 3), "velocity": (n, 3)}`` of body ``name``
    (mass-weighted centroid and velocity, as history.csv holds them)."""
    missing = [f for f in BODY_FIELDS if f"{name}.{f}" not in hist]
    if missing:
        raise KeyError(f"no body {name!r} in the history; bodies: {body_names(hist)}")
    cols = [hist[f"{name}.{f}"] for f in BODY_FIELDS]
    return {"time": hist["time"], "centroid": np.stack(cols[:3], axis=1),
            "velocity": np.stack(cols[3:], axis=1)}


def residual_velocity(hist, name, direction=None):
    """The speed of body ``name`` at the last history row: the magnitude of its
    mass-weighted velocity, or, with ``direction`` (any length), the component along it
    (positive when the body still moves that way)."""
    v = body_history(hist, name)["velocity"][-1]
    if direction is None:
        return float(np.linalg.norm(v))
    u = np.asarray(direction, float)
    return float(v @ (u / np.linalg.norm(u)))


def free_after(hist, name, tol=1e-6):
    """The time after which body ``name`` moves freely: the last history row at which its
    mass-weighted velocity changed by more than ``tol`` times its largest speed since the
    row before (an isolated body keeps its momentum exactly). For two colliding bodies
    this is when they separate; the end time if they never do."""
    v = body_history(hist, name)["velocity"]
    change = np.linalg.norm(np.diff(v, axis=0), axis=1)
    moving = np.nonzero(change > tol * max(np.linalg.norm(v, axis=1).max(), 1e-300))[0]
    return float(hist["time"][moving[-1] + 1]) if len(moving) else float(hist["time"][0])


def until_separation(hist, names):
    """The history rows up to the time the bodies ``names`` all move freely (see
    :func:`free_after`)."""
    t_free = max(free_after(hist, name) for name in names)
    keep = np.asarray(hist["time"]) <= t_free
    return {key: np.asarray(values)[keep] for key, values in hist.items()}


def travel(hist, name, axis=0):
    """(time, displacement of the centroid of ``name`` along ``axis`` since t = 0)."""
    c = body_history(hist, name)["centroid"][:, axis]
    return hist["time"], c - c[0]


def energy_steps(hist):
    """How smooth the total energy history is (seed 001 Fig. 4).

    All measures are divided by the initial kinetic energy ``K0`` (the energy put in):

    - ``max_jump``: the largest change of total energy between successive history rows
      (the "steep steps" of method 1 in Fig. 4a). It depends on how many steps apart the
      rows are (``output.history_every``); compare runs with the same spacing in time.
    - ``drift``: total energy at the end minus at the start.
    - ``variation``: the sum of the absolute changes between rows minus the absolute
      net change; 0 for a monotonic history, large for one that jumps up and down.
    - ``max_excursion``: the largest distance of the total energy from its initial value.
    """
    total, k0 = hist["total"], hist["kinetic"][0]
    if not k0 > 0:
        raise ValueError("the initial kinetic energy must be positive")
    diff = np.diff(total)
    return {"kinetic0": float(k0),
            "max_jump": float(np.abs(diff).max() / k0) if len(diff) else 0.0,
            "drift": float((total[-1] - total[0]) / k0),
            "variation": float((np.abs(diff).sum() - abs(total[-1] - total[0])) / k0),
            "max_excursion": float(np.abs(total - total[0]).max() / k0)}


def rolling_sphere_travel(t, theta, mu, g):
    """Seed 001 Eq. 36: travel along the incline of a rigid sphere released at rest on a
    rigid incline at angle ``theta`` (rad) with Coulomb friction ``mu`` under gravity
    ``g``: (1/2) g t^2 (sin theta - mu cos theta) when it slips (tan theta > 3.5 mu),
    otherwise (5/14) g t^2 sin theta (rolls without slipping)."""
    t = np.asarray(t, float)
    if rolling_sphere_slips(theta, mu):
        return 0.5 * g * t * t * (np.sin(theta) - mu * np.cos(theta))
    return 5.0 / 14.0 * g * t * t * np.sin(theta)


def rolling_sphere_slips(theta, mu):
    """True when a rigid sphere slips as it rolls down the incline: tan theta > 3.5 mu."""
    return bool(np.tan(theta) > 3.5 * mu)


# ---------------------------------------------------------------- particles.h5

def body_index(out_dir, name):
    """The ``body`` value of body ``name`` in ``out_dir/particles.h5``."""
    with h5py.File(os.path.join(out_dir, "particles.h5"), "r") as f:
        names = [n.decode() if isinstance(n, bytes) else str(n) for n in f.attrs["body_names"]]
    if name not in names:
        raise KeyError(f"no body {name!r} in {out_dir}; bodies: {names}")
    return names.index(name)


def body_points(frame, index, columns=("x",)):
    """The rows of ``frame`` (a :func:`pmpm.post.read_frame` dict) of body ``index``."""
    keep = frame["body"] == index
    return tuple(frame[c][keep] for c in columns) if len(columns) > 1 else frame[columns[0]][keep]


def min_distance(a, b, chunk=2048):
    """Smallest distance between a point of ``a`` (n, 3) and a point of ``b`` (m, 3);
    infinite if either is empty."""
    if len(a) == 0 or len(b) == 0:
        return float("inf")
    best = np.inf
    for start in range(0, len(a), chunk):
        block = a[start:start + chunk]
        d2 = (np.sum(block ** 2, axis=1)[:, None] + np.sum(b ** 2, axis=1)[None, :]
              - 2.0 * block @ b.T)
        best = min(best, float(d2.min()))
    return float(np.sqrt(max(best, 0.0)))


def connected_pieces(x, link):
    """Label the pieces a cloud of particle centres ``x`` (n, 3) falls into.

    Points are binned into cubic voxels of edge ``link``; occupied voxels that share a
    face, edge or corner belong to the same piece. So two points closer than ``link``
    are always in one piece, and points more than ``2 sqrt(3) link`` apart are never
    joined directly. A body of spacing d stretched by up to 50 % stays one piece with
    ``link = 1.5 d``.

    Returns
    -------
    labels : int array (n,)
        Piece of each point, numbered from 0 by decreasing size (0: the largest).
    sizes : int array
        Points per piece.
    """
    x = np.asarray(x, float)
    if len(x) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ijk = np.floor((x - x.min(axis=0)) / link).astype(np.int64) + 1
    dims = ijk.max(axis=0) + 2
    keys = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    voxels, inverse = np.unique(keys, return_inverse=True)
    labels = _label_voxels(voxels, dims)
    _, piece, sizes = np.unique(labels[inverse.ravel()], return_inverse=True,
                                return_counts=True)
    order = np.argsort(-sizes, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[piece.ravel()], sizes[order]


def _label_voxels(voxels, dims):
    """Smallest voxel index of each voxel's 26-connected component (sorted ``voxels``)."""
    pairs = []
    for di in (0, 1):
        for dj in (-1, 0, 1):
            for dk in (-1, 0, 1):
                if (di, dj, dk) <= (0, 0, 0):
                    continue                      # 13 of the 26 neighbours: each pair once
                shift = (di * dims[1] + dj) * dims[2] + dk
                pos = np.searchsorted(voxels, voxels + shift)
                pos = np.minimum(pos, len(voxels) - 1)
                hit = voxels[pos] == voxels + shift
                pairs.append(np.stack([np.nonzero(hit)[0], pos[hit]], axis=1))
    pairs = np.concatenate(pairs)
    labels = np.arange(len(voxels))
    while True:                                   # hook to the smaller label, then jump
        low = np.minimum(labels[pairs[:, 0]], labels[pairs[:, 1]])
        new = labels.copy()
        np.minimum.at(new, pairs[:, 0], low)
        np.minimum.at(new, pairs[:, 1], low)
        while True:
            jumped = new[new]
            if np.array_equal(jumped, new):
                break
            new = jumped
        if np.array_equal(new, labels):
            return labels
        labels = new


def count_pieces(x, link, min_size=1):
    """How many pieces of at least ``min_size`` particles ``x`` falls into
    (:func:`connected_pieces`)."""
    return int(np.sum(connected_pieces(x, link)[1] >= min_size))


def perforation(x, spacing, axis=2, centre=(0.0, 0.0), thickness=None, probe=2.0):
    """Hole diameter D, height h and h/D of a plate perforated along ``axis``.

    Parameters
    ----------
    x : (n, 3) array
        The plate's particle centres in the last frame.
    spacing : float
        The initial particle spacing d.
    axis : int
        The plate's normal, the projectile's line of flight (default z).
    centre : pair of float
        Where the line of flight crosses the plate, in the two other coordinates (the
        corner of a quarter model: (0, 0)).
    thickness : float, optional
        The plate's initial thickness, to also report the bulge below the original plate.
    probe : float
        The plate counts as perforated when its main piece keeps no particle centre
        within ``probe * spacing`` of the line of flight.

    Returns
    -------
    dict
        ``perforated`` (bool); ``D``: hole diameter, twice the smallest distance from the
        line of flight to a particle centre of the main piece, less one spacing (the hole's
        edge is the particles' faces, d/2 nearer the line than their centres); ``h``: the
        height of the deformed plate, the extent of the main piece along ``axis``, centres
        plus one spacing (d/2 above the highest centre to d/2 below the lowest, so an
        undeformed plate gives its thickness; the petals bent down by the projectile set
        the lowest point); ``h_over_D``; ``h_below``: h less ``thickness``, how far the
        deformed plate reaches beyond the original plate's far face (if ``thickness`` is
        given); ``n_pieces`` and ``detached``: pieces of the plate and the particles not in
        its main piece (plugs and fragments, which are left out).

    Notes
    -----
    The main piece is the largest piece of :func:`connected_pieces` with a link of
    1.5 spacings. Seed 001 Fig. 10 and seed 000 Fig. 16 define h as "the height of the
    final deformed plate" and D as "the diameter of penetrated hole"; for a plate that
    is still flat away from the hole, h is the distance from its undisturbed top face to
    the tips of the petals. h and D are uncertain by about one spacing.
    """
    x = np.asarray(x, float)
    labels, sizes = connected_pieces(x, 1.5 * spacing)
    main = x[labels == 0]
    others = [a for a in range(3) if a != axis]
    r = np.hypot(main[:, others[0]] - centre[0], main[:, others[1]] - centre[1])
    r_min = float(r.min())
    hole = 2.0 * r_min - spacing
    height = float(main[:, axis].max() - main[:, axis].min()) + spacing
    result = {"perforated": bool(r_min > probe * spacing), "D": hole, "h": height,
              "h_over_D": height / hole if hole > 0 else float("inf"),
              "r_min_centres": r_min, "n_pieces": int(len(sizes)),
              "detached": int(len(x) - len(main))}
    if thickness is not None:
        result["h_below"] = height - thickness
    return result
