"""The planar impact of two like bodies in uniaxial strain against its exact answer: the
Rankine-Hugoniot jump with the linear shock-particle velocity line ``Us = c0 + s up``."""
import numpy as np

from .frames import read_frame, frame_times


def rankine_hugoniot(v_rel, rho0, c0, s):
    """State behind the shock of a symmetric impact at relative speed ``v_rel``.

    Returns
    -------
    dict
        ``up`` (particle velocity jump, v_rel/2), ``Us`` (shock speed relative to the
        unshocked material), ``P`` (pressure), ``rho`` (density) and ``de`` (specific
        internal energy gained, ``up^2/2``), from mass, momentum and energy conservation
        across the shock: ``rho0 Us = rho (Us - up)``, ``P = rho0 Us up``,
        ``de = P (1/rho0 - 1/rho)/2``.
    """
    up = 0.5 * v_rel
    us = c0 + s * up
    return {"up": up, "Us": us, "P": rho0 * us * up, "rho": rho0 * us / (us - up),
            "de": 0.5 * up * up}


def shocked_state(frame, body, exact, direction):
    """The state behind one shock at one frame.

    Parameters
    ----------
    frame : dict   a frame of :func:`pmpm.post.read_frame`
    body : int     the body the shock runs into
    exact : dict   :func:`rankine_hugoniot`, for the front's threshold (P/2)
    direction : +1 or -1   the way the shock runs along x

    Returns
    -------
    dict
        ``front``: x of the shock front (the pressure crossing P/2, interpolated, seen from
        the unshocked side); ``p``, ``rho``, ``v``, ``e``: means over the plateau, the
        middle half of the shocked part between the impact face and the front (which
        leaves out the start-up transient at the face and the front's own width);
        ``p_sd``: the plateau's pressure scatter; ``n``: the plateau's particle count.
    """
    own = frame["body"] == body
    x = frame["x"][own, 0] * direction
    p = -frame["stress"][own, :3].mean(axis=1)
    order = np.argsort(-x, kind="stable")            # from the unshocked side inwards
    x, p = x[order], p[order]
    half = 0.5 * exact["P"]
    k = int(np.argmax(p > half)) if np.any(p > half) else len(p) - 1
    front = x[k] if k == 0 else x[k] + (x[k - 1] - x[k]) * (p[k] - half) / (p[k] - p[k - 1])
    face = x.min()
    lo, hi = face + 0.25 * (front - face), front - 0.25 * (front - face)
    sel = np.zeros(own.sum(), bool)
    sel[order[(x > lo) & (x < hi)]] = True
    pick = np.flatnonzero(own)[sel]
    pr = -frame["stress"][pick, :3].mean(axis=1)
    return {"front": float(front * direction), "p": float(pr.mean()),
            "p_sd": float(pr.std()), "rho": float(frame["density"][pick].mean()),
            "v": float(frame["v"][pick, 0].mean()), "e": float(frame["e_int"][pick].mean()),
            "n": int(pick.size)}


def planar_shock_errors(out_dir, v_flyer, v_target, rho0, c0, s, start=1):
    """Measured shocked state of a planar impact (body 0 the flyer moving along +x,
    body 1 the target) against :func:`rankine_hugoniot`, as relative errors.

    The plateau values are those of the last frame; each shock speed is the slope of a
    straight line through the fronts of frames ``start`` onwards (frame 0 is the start)
    relative to the unshocked material. Returns ``{"exact", "flyer", "target", "errors"}``
    where ``errors`` holds, per body, the relative errors of ``Us``, ``P``, ``rho``,
    ``up`` (the measured velocity jump) and ``de`` (the plateau's specific energy).
    """
    exact = rankine_hugoniot(v_flyer - v_target, rho0, c0, s)
    times = frame_times(out_dir)[start:]
    frames = [read_frame(out_dir, i) for i in range(start, start + len(times))]
    result = {"exact": exact, "times": times}
    for name, body, v0, way in (("flyer", 0, v_flyer, -1), ("target", 1, v_target, +1)):
        states = [shocked_state(f, body, exact, way) for f in frames]
        speed = np.polyfit(times, [st["front"] for st in states], 1)[0] if len(times) > 1 \
            else float("nan")
        last = dict(states[-1])
        last["Us"] = abs(float(speed) - v0)
        last["up"] = abs(last["v"] - v0)
        last["fronts"] = [st["front"] for st in states]
        result[name] = last
    result["errors"] = {
        name: {"Us": result[name]["Us"] / exact["Us"] - 1.0,
               "P": result[name]["p"] / exact["P"] - 1.0,
               "rho": result[name]["rho"] / exact["rho"] - 1.0,
               "up": result[name]["up"] / exact["up"] - 1.0,
               "de": result[name]["e"] / exact["de"] - 1.0}
        for name in ("flyer", "target")}
    return result
