"""The step's ceiling (issue 25): how close each phase of the default (USF) step comes to
this machine's memory and arithmetic bounds, on the Taylor bar at 0.38 mm (169,376
particles) with the hats and with gimp.

Three parts, written to results/bench/ceiling.{json,md}:

1. The machine, one thread, Numba: STREAM copy and triad on arrays far beyond the caches
   (the memory bandwidth; the same triad on 4 MB arrays for the caches'), and the rate of
   double-precision multiply-adds: twelve independent scalar chains with LLVM's
   vectorisers off (scalar), and an element-wise ``y = y b + c`` over an L1-resident
   array, vectorised (SIMD), each without and with ``fastmath`` (which contracts the
   multiply and add into one FMA).
2. Per phase and shape, the bytes a particle-step moves and the flops it does, counted
   from the kernels (:data:`COUNTS`, each term named after the code it counts): particle
   columns at their dtype's size (read, and written again where written); nodal arrays
   at the node count, once per step (a phase's grid rows stay in cache while its
   particles, sorted by cell, walk them), divided by the particle count.
3. Per phase, its time in the real run: the bar is set up in this process and stepped
   ``--warm`` steps (the plastic foot forms), then each phase of the step is called as
   the Stepper calls it, ``--repeat`` times from the same state (the particle columns
   restored between calls), median of the CPU times. The fused stress-and-force pass is
   also timed in parts: the weights and gradients alone (a loop in this script over the
   kernels' own shape functions), stresses without forces, forces without stresses, and
   the constitutive update alone (from gradients computed beforehand); the velocity
   gradient's row is the stress pass less that update.

The bound of a phase is max(bytes / copy bandwidth, flops / rate); the table gives the
measured time over each bound. Flops count +, -, *, / and sqrt as one each (floor, abs,
min, max and copysign as one each where the shapes use them), as written in the source;
LLVM may fuse or drop a few.

Usage: .venv/bin/python scripts/ceiling.py [--shapes linear gimp] [--warm 40]
                                           [--repeat 7] [--out results/bench]
                                           [--page docs/performance.md]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np
from numba import njit

from _common import ROOT, save_json, write_lines
import bench
import performance_page
from pmpm.kernels.shape import LINEAR, MAX_NODES, point_axes, stencil
from pmpm.materials.kernels import update_stress_columns

CASE = os.path.join(ROOT, "runs", "taylor_bar.yaml")
SETS = ["params.cell=0.38", "time.end=0.01", "output.frames=1"]
PHASES = ("weights", "particle-to-grid", "grid update", "stress", "velocity gradient",
          "constitutive update", "forces", "stress and forces (fused)", "grid-to-particle")

# -- 1. the machine --------------------------------------------------------------------


@njit(cache=False)
def stream_copy(a, b):
    for i in range(a.shape[0]):
        b[i] = a[i]


@njit(cache=False)
def stream_triad(a, b, c, s):
    for i in range(a.shape[0]):
        a[i] = b[i] + s * c[i]


def fma_chains(fast):
    """Twelve independent chains a = a b + c: the scalar units' throughput (with LLVM's
    vectorisers off: ``--scalar`` runs in a child process with them disabled)."""
    @njit(fastmath=fast, cache=False)
    def chains(n, b, c):
        a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = a8 = a9 = a10 = a11 = 1.0
        for _ in range(n):
            a0, a1, a2, a3 = a0 * b + c, a1 * b + c, a2 * b + c, a3 * b + c
            a4, a5, a6, a7 = a4 * b + c, a5 * b + c, a6 * b + c, a7 * b + c
            a8, a9, a10, a11 = a8 * b + c, a9 * b + c, a10 * b + c, a11 * b + c
        return a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7 + a8 + a9 + a10 + a11
    return chains


def fma_array(fast):
    """y = y b + c over an array in L1, repeated: the vector units' throughput (each
    multiply-add loads and stores its element)."""
    @njit(fastmath=fast, cache=False)
    def sweep(y, reps, b, c):
        for _ in range(reps):
            for i in range(y.shape[0]):
                y[i] = y[i] * b + c
    return sweep


def best_of(call, repeats=5):
    """The least CPU time of ``call()`` (CPU, not wall: the machine is shared)."""
    call()
    times = []
    for _ in range(repeats):
        start = time.process_time()
        call()
        times.append(time.process_time() - start)
    return min(times)


def memory_rates():
    """GB/s of STREAM copy (16 B an element) and triad (24 B) on 256 MB arrays, and of the
    triad on 4 MB arrays (L2/L3)."""
    n = 1 << 25
    a, b, c = np.ones(n), np.ones(n), np.ones(n)
    rates = {"copy_GBs": 16 * n / best_of(lambda: stream_copy(a, b)) / 1e9,
             "triad_GBs": 24 * n / best_of(lambda: stream_triad(a, b, c, 0.5)) / 1e9}
    m, sweeps = 1 << 19, 50
    a, b, c = np.ones(m), np.ones(m), np.ones(m)

    def cached():
        for _ in range(sweeps):
            stream_triad(a, b, c, 0.5)
    rates["triad_4MB_GBs"] = 24 * m * sweeps / best_of(cached) / 1e9
    return rates


def arithmetic_rates(vectorised):
    """GFlop/s (a multiply-add: 2 flops) of the chains (scalar) or of the array sweep
    (SIMD), without and with fastmath."""
    rates = {}
    for fast in (False, True):
        tag = "fastmath" if fast else "plain"
        if vectorised:
            y, reps = np.ones(512), 200_000
            sweep = fma_array(fast)
            rates[f"simd_{tag}_GFs"] = 2 * 512 * reps / best_of(
                lambda: sweep(y, reps, 0.999999, 1e-9)) / 1e9
        else:
            n = 20_000_000
            chains = fma_chains(fast)
            rates[f"scalar_{tag}_GFs"] = 24 * n / best_of(
                lambda: chains(n, 0.999999, 1e-9)) / 1e9
    return rates


def machine():
    """Memory and SIMD rates here; the scalar rates in a child process whose Numba has
    its loop and SLP vectorisers off."""
    env = dict(os.environ, NUMBA_LOOP_VECTORIZE="0", NUMBA_SLP_VECTORIZE="0")
    child = subprocess.run([sys.executable, __file__, "--scalar"], env=env, check=True,
                           capture_output=True, text=True)
    rates = memory_rates()
    rates.update(arithmetic_rates(vectorised=True))
    rates.update(json.loads(child.stdout.strip().splitlines()[-1]))
    rates["cpu"] = cpu_name()
    return rates


def cpu_name():
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown"


# -- 2. what a particle-step moves and computes -------------------------------------------

#: bytes a particle holds in each column the step touches (the store's dtypes)
COLUMN_BYTES = {"x": 24, "v": 24, "mass": 8, "body": 4, "level": 4, "stress": 48, "F": 72,
                "rho": 8, "eps_p": 8, "e_int": 8, "temp": 8, "q": 8, "damage": 8, "w_p": 8,
                "load": 4, "load_scale": 8}
MATERIAL = ("stress", "F", "rho", "eps_p", "e_int", "temp", "q", "damage", "w_p")

#: per phase: particle columns read and written; nodal bytes per node read and written
#: (8 B a column; a zeroed array counts as written once more); flops per particle-step
#: for each shape, as named sums (pmpm.kernels.mpm, pmpm.kernels.shape,
#: pmpm.materials.kernels); "grid update" counts flops per node.
#: gimp's 1D weights per axis (pmpm.kernels.shape._gimp_three): s, c = floor(s + 1/2),
#: d, the offsets d +- 1 (7); 1 / (4 lp), 2 lp, t = max(lp -+ d, 0) (6); per outer node
#: u = min(t, 2 lp), u^2 / (4 lp) + (t - u) (5 x 2); the middle 1 - w0 - w2 (2); the
#: slopes: 1 / (2 lp), per outer node t, u and the scale again (4 x 2), the middle (2).
#: Then the derivatives times 1/h (9).
GIMP_WEIGHTS = 3 * (7 + 6 + 10 + 2)
GIMP_AXES = GIMP_WEIGHTS + 3 * 11 + 9

COUNTS = {
    "weights": {
        "read": ("x", "body", "level"), "written": (), "node_read": 0, "node_written": 0,
        # hats: per axis s = (x - o) h^-1, floor, r = s - c, 1 - r (4 x 3); per node
        # w = wx wy wz, and gx, gy, gz two products each (8 x 8).  gimp: GIMP_AXES
        "flops": {"linear": 12 + 64, "gimp": GIMP_AXES},
    },
    "particle-to-grid": {
        "read": ("x", "v", "mass", "body", "level"), "written": (),
        # nodal (8 columns) zeroed, then mass and momentum (4 columns) read and written
        "node_read": 4 * 8, "node_written": 8 * 8 + 4 * 8,
        # weights without gradients (hats: 12 + 3 + 4 + 8 products; gimp: GIMP_WEIGHTS),
        # then per node m w and 4 adds, 3 products (gimp: m w_a w_b per row, times w_c)
        "flops": {"linear": 27 + 8 * 8, "gimp": GIMP_WEIGHTS + 9 * 2 + 27 * 8},
    },
    "grid update": {
        "read": (), "written": (),
        # nodal_velocities: nodal (8 columns), faces (2 B) -> gvel (3); integrate_nodes:
        # mass and rigid mass, force (3), gvel (3), faces -> gnew (6)
        "node_read": 8 * 8 + 2 + 2 * 8 + 3 * 8 + 3 * 8 + 2, "node_written": 3 * 8 + 6 * 8,
        # per node with mass: 3 quotients (velocity), 3 quotients (acceleration), 3 x (*, +)
        "flops": {"linear": 12, "gimp": 12}, "per_node": True,
    },
    "stress": {
        "read": ("x", "v", "body", "level") + MATERIAL, "written": MATERIAL,
        "node_read": 3 * 8, "node_written": 0,
        # weights and gradients; L = sum v g (hats: 8 nodes x 9 (*, +); gimp: 9 rows x
        # (3 nodes x 12 + 3 + 18)); Johnson-Cook (no EOS, no viscosity here): sym and
        # skew parts (15), density and volume (8), Jaumann rotation (36), deviators (12),
        # trial stress (12), two double dots (22), von Mises (12 and a sqrt), yield stress
        # and return (about 25), energy (about 15), wave speed (about 8 and a sqrt), the
        # speed's norm (6): about 170
        "flops": {"linear": 76 + 8 * 18 + 170, "gimp": GIMP_AXES + 9 * (36 + 3 + 18) + 170},
    },
    # the stress pass in two: the velocity gradient (with its weights) and the update
    "velocity gradient": {
        "read": ("x", "body", "level"), "written": (), "node_read": 3 * 8, "node_written": 0,
        "flops": {"linear": 76 + 8 * 18, "gimp": GIMP_AXES + 9 * (36 + 3 + 18)},
    },
    "constitutive update": {
        "read": ("v", "body") + MATERIAL, "written": MATERIAL, "node_read": 0,
        "node_written": 0, "flops": {"linear": 170, "gimp": 170},
    },
    "forces": {
        "read": ("x", "mass", "body", "level", "rho", "stress", "q", "load", "load_scale"),
        "written": (),
        # force (3 columns) zeroed, read and written
        "node_read": 3 * 8, "node_written": 2 * 3 * 8,
        # weights and gradients; vol, s - q, m g (7); hats per node 3 x (5 *, 3 +-) and 3
        # adds (27 x 8); gimp per row 3 products, p (3 x 6), q (3 x 2), per node 3 x
        # (2 *, 1 +) and 3 adds
        "flops": {"linear": 76 + 7 + 27 * 8, "gimp": GIMP_AXES + 7 + 9 * (3 + 18 + 6) + 27 * 12},
    },
    "grid-to-particle": {
        "read": ("x", "v", "body", "level"), "written": ("x", "v"),
        "node_read": 6 * 8, "node_written": 0,
        # weights without gradients; per node 6 (*, +) (gimp: and the node's product);
        # x += dt dx, v += dt dv (12)
        "flops": {"linear": 27 + 8 * 12 + 12, "gimp": GIMP_WEIGHTS + 9 + 27 * 13 + 12},
    },
}
# the fused pass reads each column once: the union of the two parts, weights once
_FUSED_FLOPS = {s: COUNTS["stress"]["flops"][s] + COUNTS["forces"]["flops"][s]
                - COUNTS["weights"]["flops"][s] for s in ("linear", "gimp")}
COUNTS["stress and forces (fused)"] = {
    "read": tuple(dict.fromkeys(COUNTS["stress"]["read"] + COUNTS["forces"]["read"])),
    "written": MATERIAL, "node_read": 2 * 3 * 8, "node_written": 2 * 3 * 8,
    "flops": _FUSED_FLOPS}


def traffic(phase, shape, n_particles, n_nodes):
    """(bytes, flops) per particle-step of ``phase``."""
    c = COUNTS[phase]
    particle = sum(COLUMN_BYTES[k] for k in c["read"]) + sum(COLUMN_BYTES[k] for k in c["written"])
    nodes = (c["node_read"] + c["node_written"]) * n_nodes / n_particles
    flops = c["flops"][shape] * (n_nodes / n_particles if c.get("per_node") else 1.0)
    return particle + nodes, flops


# -- 3. the phases in the real run -------------------------------------------------------


@njit(cache=True, inline="always")
def stencil_scratch():
    """One particle's stencil arrays (node ids, the 1D axes, weights and gradients),
    made once per kernel call and reused for every particle."""
    return (np.empty(MAX_NODES, np.int64), np.empty((9, 3)), np.empty(MAX_NODES),
            np.empty(MAX_NODES), np.empty(MAX_NODES), np.empty(MAX_NODES))


@njit(cache=True)
def weights_and_gradients(pts, geo):
    """The stress pass's weights and gradients of every particle, alone (its loop
    without the velocity gradient, stress and force): the sum of every weight and
    gradient, so that nothing is dropped."""
    x, _, _, body, _ = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)
    nodes, axes, w, gx, gy, gz = stencil_scratch()
    total = 0.0
    for p in range(x.shape[0]):
        if shape == LINEAR:
            reach = stencil(x, p, origin, inv_h, lo, strides, shape, half_width[body[p]],
                            axes, nodes, w, gx, gy, gz)
            for k in range(reach):
                total += w[k] + gx[k] + gy[k] + gz[k] + nodes[k]
        else:
            base, _ = point_axes(x, p, origin, inv_h, lo, strides, shape,
                                 half_width[body[p]], axes)
            for d in range(3):
                for j in range(3):
                    axes[3 * d + 1, j] *= inv_h
                    total += axes[3 * d, j] + axes[3 * d + 1, j]
            total += base
    return total


@njit(cache=True)
def velocity_gradients(pts, geo, gvel, lgs):
    """Every particle's velocity gradient from ``gvel`` into ``lgs`` (n, 3, 3), node by
    node (:func:`pmpm.kernels.shape.stencil`; the step's gimp pass sums by rows, the same
    products in another order): the input of :func:`constitutive_updates`, untimed."""
    x, _, _, body, _ = pts
    origin, inv_h, lo, strides, marker, half_width = geo
    shape = len(marker)
    nodes, axes, w, gx, gy, gz = stencil_scratch()
    for p in range(x.shape[0]):
        reach = stencil(x, p, origin, inv_h, lo, strides, shape, half_width[body[p]], axes,
                        nodes, w, gx, gy, gz)
        l00 = l01 = l02 = l10 = l11 = l12 = l20 = l21 = l22 = 0.0
        for k in range(reach):
            n = nodes[k]
            u0, u1, u2 = gvel[n, 0], gvel[n, 1], gvel[n, 2]
            l00, l01, l02 = l00 + u0 * gx[k], l01 + u0 * gy[k], l02 + u0 * gz[k]
            l10, l11, l12 = l10 + u1 * gx[k], l11 + u1 * gy[k], l12 + u1 * gz[k]
            l20, l21, l22 = l20 + u2 * gx[k], l21 + u2 * gy[k], l22 + u2 * gz[k]
        lgs[p, 0, 0], lgs[p, 0, 1], lgs[p, 0, 2] = l00, l01, l02
        lgs[p, 1, 0], lgs[p, 1, 1], lgs[p, 1, 2] = l10, l11, l12
        lgs[p, 2, 0], lgs[p, 2, 1], lgs[p, 2, 2] = l20, l21, l22


@njit(cache=True)
def constitutive_updates(pts, mat, bodies, dt, h, lgs):
    """The stress pass's constitutive update of every particle from its gradient in
    ``lgs`` and its speed, alone; returns the fastest wave plus particle speed."""
    _, v, _, body, _ = pts
    stress, F, rho, eps_p, e_int, temp, q, damage, w_p = mat
    codes, params, _ = bodies
    fastest = 0.0
    for p in range(v.shape[0]):
        b = body[p]
        c = update_stress_columns(p, codes[b], params[b], dt, h, lgs[p], stress, F, rho,
                                  eps_p, e_int, temp, q, damage, w_p)
        fastest = max(fastest, c + np.sqrt(v[p, 0] ** 2 + v[p, 1] ** 2 + v[p, 2] ** 2))
    return fastest


def set_up_bar(shape, warm):
    """The Taylor bar at 0.38 mm with ``shape``, stepped ``warm`` steps as the run loop
    steps it (the cfl step, sorted by cell every SORT_EVERY steps)."""
    from mpi4py import MPI
    from pmpm.case import fill_body
    from pmpm.case.loader import load_config
    from pmpm.comm import World
    from pmpm.solver.run import SORT_EVERY
    from pmpm.solver.simulation import Simulation
    config = load_config(CASE, SETS + [f"grid.shape_functions={shape}"])
    sim = Simulation.from_config(World(MPI.COMM_SELF), config, os.path.dirname(CASE),
                                 fill_body)
    cfl = float(config.time.cfl)
    for _ in range(warm):
        sim.advance(cfl * sim.grid.h / sim.fastest_speed())
        if sim.step_count % SORT_EVERY == 0:
            sim.sort_by_cell()
    return sim, cfl * sim.grid.h / sim.fastest_speed()


class Snapshot:
    """The particle columns a phase writes, put back before each timed call."""

    NAMES = ("x", "v") + MATERIAL

    def __init__(self, particles):
        self.particles = particles
        self.saved = {k: getattr(particles, k).copy() for k in self.NAMES}

    def restore(self):
        for k, saved in self.saved.items():
            getattr(self.particles, k)[...] = saved


def cpu_median(call, before, repeats):
    """Median CPU seconds of ``call()`` over ``repeats`` calls, ``before()`` (untimed)
    ahead of each; one untimed call first."""
    before()
    call()
    times = []
    for _ in range(repeats):
        before()
        start = time.process_time()
        call()
        times.append(time.process_time() - start)
    return statistics.median(times)


def phase_times(sim, dt, repeats):
    """CPU seconds of each phase of one step (median of ``repeats``), from one state."""
    stepper = sim.stepper
    kind = stepper.grid_kinds[0]
    state = next(iter(stepper.grids))
    snapshot = Snapshot(kind.particles)
    stepper.decomposition.assign_levels(stepper.moving_kinds)
    stepper.decomposition.build_blocks()

    def fresh_grid():
        """The state a phase starts from: columns restored, mass, velocities and forces
        of the start of the step on the grid."""
        snapshot.restore()
        stepper.map_to_grid()
        stepper.nodal_velocities()

    def fresh_forces():
        fresh_grid()
        stepper.stress_and_forces(dt)

    def fresh_integrated():
        fresh_forces()
        stepper.integrate(dt)

    lgs = np.zeros((kind.particles.n, 3, 3))
    fresh_grid()
    velocity_gradients(kind.points(), state.geometry, state.gvel, lgs)

    def zero_forces():
        stepper.grids.zeros("force", 3)

    def grid_update():
        stepper.nodal_velocities()
        stepper.integrate(dt)

    times = {
        "weights": cpu_median(lambda: weights_and_gradients(kind.points(), state.geometry),
                              fresh_grid, repeats),
        "particle-to-grid": cpu_median(stepper.map_to_grid, snapshot.restore, repeats),
        "grid update": cpu_median(grid_update, fresh_forces, repeats),
        "stress": cpu_median(lambda: kind.particle_pass(state, dt, None, True, False),
                             fresh_grid, repeats),
        "constitutive update": cpu_median(
            lambda: constitutive_updates(kind.points(), kind.particles.material,
                                         kind.materials, dt, state.level.h, lgs),
            snapshot.restore, repeats),
        "forces": cpu_median(lambda: (zero_forces(), kind.particle_pass(state, dt, None,
                                                                        False, True)),
                             fresh_grid, repeats),
        "stress and forces (fused)": cpu_median(lambda: stepper.stress_and_forces(dt),
                                                fresh_grid, repeats),
        "grid-to-particle": cpu_median(lambda: stepper.update_points(dt), fresh_integrated,
                                       repeats),
    }
    # the stress pass less its constitutive update (the gradient is summed by rows there)
    times["velocity gradient"] = times["stress"] - times["constitutive update"]
    snapshot.restore()
    whole = cpu_median(lambda: sim.advance(dt), snapshot.restore, repeats)
    return times, whole, state.nodal.shape[0]


def measure_shape(shape, warm, repeats, rates):
    sim, dt = set_up_bar(shape, warm)
    n = sim.particles.n
    times, whole, n_nodes = phase_times(sim, dt, repeats)
    bandwidth = rates["copy_GBs"] * 1e9
    scalar = max(rates["scalar_plain_GFs"], rates["scalar_fastmath_GFs"]) * 1e9
    simd = max(rates["simd_plain_GFs"], rates["simd_fastmath_GFs"]) * 1e9
    rows = []
    for phase in PHASES:
        moved, flops = traffic(phase, shape, n, n_nodes)
        t = times[phase] / n
        rows.append({"phase": phase, "ns": 1e9 * t, "bytes": moved, "flops": flops,
                     "memory_ns": 1e9 * moved / bandwidth, "scalar_ns": 1e9 * flops / scalar,
                     "simd_ns": 1e9 * flops / simd})
    return {"shape": shape, "particles": n, "nodes": n_nodes, "warm_steps": warm,
            "repeats": repeats, "step_ns": 1e9 * whole / n,
            "step_M_per_s": n / whole / 1e6, "phases": rows}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", nargs="+", default=["linear", "gimp"])
    parser.add_argument("--warm", type=int, default=40, help="steps before the timing")
    parser.add_argument("--repeat", type=int, default=7, help="timed calls of each phase")
    parser.add_argument("--out", default=os.path.join(ROOT, "results", "bench"))
    parser.add_argument("--page", metavar="PATH", help="then put the ceiling's section into "
                        "this page (e.g. docs/performance.md)")
    parser.add_argument("--scalar", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.scalar:                      # the child of machine(): vectorisers off
        print(json.dumps(arithmetic_rates(vectorised=False)))
        return
    rates = machine()
    print(json.dumps(rates))
    made = dict(bench.provenance(), command=" ".join(["python scripts/ceiling.py"] + sys.argv[1:]))
    data = {**made, "machine": rates,
            "case": {"file": os.path.relpath(CASE, ROOT), "set": SETS},
            "shapes": [measure_shape(s, args.warm, args.repeat, rates) for s in args.shapes]}
    save_json(os.path.join(args.out, "ceiling.json"), data)
    write_lines(os.path.join(args.out, "ceiling.md"), performance_page.ceiling_table(data),
                echo=True)
    if args.page:
        performance_page.write_section("ceiling", os.path.join(args.out, "ceiling.json"),
                                       args.page)


if __name__ == "__main__":
    main()
