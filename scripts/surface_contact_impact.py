"""Issue 24's two ICFEMP impacts, in process, one rank: the figures of
docs/validation/surface_contact_impact.md.

    python scripts/surface_contact_impact.py sphere 1.0     # or 0.5; bar 0.5 [--set-like KEY=VALUE ...]
    python scripts/surface_contact_impact.py sphere-sweep 1.0 10 [KEY=VALUE ...]

``sphere-sweep CELL N``: the sphere at N placements over one period of the particle
lattice (``params.gap`` = k s / N, k = 0 .. N-1, s the particle spacing cell / ppc): how
the lattice cuts the sphere sets its lowest layer, a flat disk whose size decides the
first contact. One JSON line per placement, then one with each figure's mean, lowest
and highest over the placements.

Prints one JSON line (sphere: peak force, contact time against Hertz at the case's speed
``params.v``, rebound, energy at time.end, the run stopped if a particle left the grid;
the largest fall of the sphere's centre (``centre_drop``; Hertz's approach 0.274 mm) and
of the block's top under it (``top_drop``; Hertz: half the approach), and how far the
lowest layer of the sphere's particles closed on the block's top over the run
(``closing``: the particle centres' gap to the block's surface, FE top node or top
particle plus its half spacing, at the start less its smallest; 0 when the contact holds
them at their half spacing, > 0 when they sink into the block);
bar: stress plateau / (rho c v / 2), pulse length / 2 Ls, striker stop time / (2 Ls / c),
final striker speed / v0, energy)."""
import os, sys, time, json
import numpy as np
HERE = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tests")

def simulation(case, overrides=()):
    from pmpm.case import fill_body
    from pmpm.case.loader import load_config
    from pmpm.comm import World
    from pmpm.solver.simulation import Simulation
    from mpi4py import MPI
    path = os.path.join(HERE, "cases", case)
    config = load_config(path, list(overrides))
    return Simulation.from_config(World(MPI.COMM_SELF), config, os.path.dirname(path), fill_body), config

def run(sim, end, cfl, every):
    while sim.time < end - 1e-12:
        dt = min(cfl * sim.grid.h / sim.fastest_speed(), end - sim.time)
        sim.advance(dt)
        every(sim)

def sphere(cell=1.0, extra=(), end=0.03):
    import math
    sim, cfg = simulation("sphere_on_fem_block.yaml", [f"params.cell={cell}"] + list(extra))
    p = sim.particles
    sph = p.body == 1
    v = -float(p.mass[sph] @ p.v[sph, 2] / p.mass[sph].sum())     # the impact speed
    rec = []
    e0 = sim.energies()["total"]
    lowest = block_surface = None
    def ev(s):
        nonlocal lowest, block_surface
        p = s.particles; b = p.body == 1
        if lowest is None:
            lowest, block_surface = lowest_layer(s), top_under_axis(s)
        vz = p.mass[b] @ p.v[b, 2] / p.mass[b].sum()
        zc = p.mass[b] @ p.x[b, 2] / p.mass[b].sum()
        rec.append((s.time, vz, zc, s.energies()["total"], s.surface.last_pairs if s.surface else 0, s.surface.largest_penetration if s.surface else 0.0,
                    block_surface(s), p.x[lowest, 2].mean()))
    t0 = time.time()
    run(sim, end, cfg.time.cfl, ev)
    r = np.array(rec)
    if sim.lost:        # a particle that left the grid took its energy with it
        raise SystemExit(f"{sim.lost} particles left the grid: the figures would not hold")
    R, rho, E, nu = 5.0, 7.85e-3, 2e5, 0.3
    m = rho * 4 / 3 * math.pi * R ** 3; ee = E / (2 * (1 - nu ** 2))
    d = (15 * m * v ** 2 / (16 * ee * math.sqrt(R))) ** 0.4
    F = 4 / 3 * ee * math.sqrt(R) * d ** 1.5
    tc = 2.868 * (m ** 2 / (R * ee ** 2 * v)) ** 0.2
    t, vz = r[:, 0], r[:, 1]
    w = max(1, int(round(tc / 40 / np.median(np.diff(t)))))
    f = m * (vz[w:] - vz[:-w]) / (t[w:] - t[:-w])
    touching = np.flatnonzero(f > 0.02 * f.max())
    mid = 0.5 * (t[w:] + t[:-w])
    ct = mid[touching[-1]] - mid[touching[0]]
    from pmpm.post.hertz import hertz_share_above
    out = dict(cell=cell, force=f.max() / F - 1, contact_time=ct / (tc * hertz_share_above(0.02)) - 1,
               rebound=-vz[-1] / vz[0], energy=r[-1, 3] / e0 - 1, min_energy=r[:, 3].min() / e0 - 1,
               maxpen=r[:, 5].max(), wall=time.time() - t0, steps=len(r),
               centre_drop=float(r[0, 2] - r[:, 2].min() + v * r[0, 0]),
               top_drop=float(r[0, 6] - r[:, 6].min()),
               closing=float((r[0, 7] - r[0, 6]) - (r[:, 7] - r[:, 6]).min()))
    return out, r

FIGURES = ("force", "contact_time", "rebound", "energy", "min_energy")


def sphere_sweep(cell, n, extra=()):
    """The sphere at ``n`` placements over one lattice period (its spacing cell / ppc,
    ``params.ppc`` from ``extra`` or the case's 2); each placement's figures printed as
    it ends, and returned: each figure's mean, lowest and highest."""
    ppc = next((float(e.split("=", 1)[1]) for e in extra if e.startswith("params.ppc=")), 2.0)
    spacing = cell / ppc
    rows = []
    for k in range(n):
        out, _ = sphere(cell, [f"params.gap={k * spacing / n!r}"] + list(extra))
        out["gap"] = k * spacing / n
        print(json.dumps(out), flush=True)
        rows.append(out)
    return {"cell": cell, "placements": n, **{
        f: {"mean": float(np.mean([r[f] for r in rows])), "lowest": min(r[f] for r in rows),
            "highest": max(r[f] for r in rows)} for f in FIGURES}}


def lowest_layer(sim):
    """The sphere's particles of its lowest layer (within a quarter spacing of the
    lowest) near the axis (within a cell of it)."""
    p = sim.particles
    b = np.flatnonzero(p.body == 1)
    z = p.x[b, 2]
    near = (np.hypot(p.x[b, 0], p.x[b, 1]) < sim.grid.h) & \
        (z < z.min() + 0.25 * np.cbrt(p.vol0[b]))
    return b[near]

def top_under_axis(sim):
    """A function of the simulation: the height of the block's top surface on the axis
    (FE: the top node there; particles: the highest particle within a cell of the axis
    plus its half spacing)."""
    fem = sim.elements
    if fem is not None and len(getattr(fem, "x", ())):
        node = int(np.argmin(np.linalg.norm(fem.x - [0.0, 0.0, fem.x[:, 2].max()], axis=1)))
        return lambda s: s.elements.x[node, 2]
    p = sim.particles
    b = np.flatnonzero(p.body == 0)
    b = b[np.hypot(p.x[b, 0], p.x[b, 1]) < sim.grid.h]
    top = b[np.argmax(p.x[b, 2])]
    half = 0.5 * np.cbrt(p.vol0[top])
    return lambda s: s.particles.x[top, 2] + half

def bar(cell=0.5, extra=(), end=0.012, t_profile=0.008):
    sim, cfg = simulation("striker_on_fem_bar.yaml", [f"params.cell={cell}"] + list(extra))
    rec, prof = [], {}
    def ev(s):
        p = s.particles; b = p.body == 0
        vx = p.mass[b] @ p.v[b, 0] / p.mass[b].sum()
        rec.append((s.time, vx, s.energies()["total"], s.surface.last_pairs if s.surface else 0))
        if not prof and s.time >= t_profile - 1e-12:
            fem = s.elements
            if fem:
                c = fem.centroids(); prof["x"] = c[:, 0].copy(); prof["s"] = fem.state.stress[:, 0].copy()
            else:
                bb = p.body == 1
                prof["x"] = p.x[bb, 0].copy(); prof["s"] = p.stress[bb, 0].copy()
    run(sim, end, cfg.time.cfl, ev)
    r = np.array(rec)
    c = np.sqrt(1e5 / 5e-3); v0 = 10.0; sig = 5e-3 * c * v0 / 2
    x, s = prof["x"], prof["s"]
    order = np.argsort(x); x, s = x[order], s[order]
    loaded = -s > 0.5 * sig
    # pulse length: extent where stress exceeds half the theoretical level
    xs = x[loaded]
    length = xs.max() - xs.min() if len(xs) else 0
    # plateau: median over the loaded part
    plateau = np.median(-s[loaded]) / sig if len(xs) else 0
    # striker stop time: first time vx < 0.02 v0
    stop = r[np.flatnonzero(r[:, 1] < 0.02 * v0)[0], 0] if (r[:, 1] < 0.02 * v0).any() else np.nan
    out = dict(cell=cell, plateau=plateau, pulse=length / 20.0, stop=stop / (2 * 10.0 / c) if stop == stop else None,
               v_end=r[-1, 1] / v0, energy=r[-1, 2] / r[0, 2] - 1, min_s=(-s).max() / sig)
    return out, r, (x, s)

if __name__ == "__main__":
    which = sys.argv[1]
    cell = float(sys.argv[2])
    extra = sys.argv[3:]
    if which == "sphere-sweep":
        print(json.dumps(sphere_sweep(cell, int(extra[0]), extra[1:])))
        sys.exit(0)
    if which == "sphere":
        out, r = sphere(cell, extra)
        pass
    else:
        out, r, prof = bar(cell, extra)
        pass
    print(json.dumps(out))
