"""The run loop: time-step control, output schedule, history, checkpoints, summary."""
import os
import time as clock

import numpy as np

from .. import io
from ..case.config import converted_into
from ..io.derived import Deferred, deferred_frame_columns
from ..io.bodies_xdmf import BodiesXdmf
from ..io.elements_h5 import ElementWriter
from ..io.forces import ForcesWriter
from ..io.probes import ProbeWriter
from ..io.checkpoint import checkpoint_path
from .errors import SolverError
from .estimate import STEP_SLACK
from .energy import EnergyWatch, LoadWork
from .interrupt import RunInterrupted, received, signal_name
from .memory import memory_summary
from .probes import COLUMNS as PROBE_COLUMNS, Probes
from .progress import Progress
from .startup import since_process_start
from .step_limit import ElementStepLimit

SORT_EVERY = 20


class Schedule:
    """Output times: ``frames`` equal intervals up to ``end``, the multiples of ``every``
    and any listed ``times``."""

    def __init__(self, output, end):
        n = max(output.frames, 1)
        times = set(np.linspace(0.0, end, n + 1)[1:].tolist())
        if output.every:                # its multiples, the last one within round-off
            count = int(np.floor(end / output.every * (1 + 1e-12)))
            times.update(min(k * output.every, end) for k in range(1, count + 1))
        times.update(t for t in output.times if 0 < t <= end)
        self.times = []
        for t in sorted(times):         # one frame for times equal within round-off
            if not self.times or t - self.times[-1] > 1e-9 * end:
                self.times.append(t)
            elif t == end:
                self.times[-1] = end

    def next_after(self, t, eps):
        return next((s for s in self.times if s > t + eps), None)


def body_energies(stats):
    """[kinetic, internal, plastic, hourglass] of one body's stats: the internal energy
    holds the plastic work and the elements' hourglass energy (0 for particles), so that
    the bodies' energies add up to the totals."""
    e = stats["energy"]
    hourglass = e.get("hourglass", 0.0)
    return [e["kinetic"], e["internal"] + hourglass, e["plastic"], hourglass]


class Runner:
    """Drives a :class:`Simulation` to ``time.end`` and writes the run contract's files."""

    def __init__(self, sim, out_dir, case_text, progress=True, restart=None, case=None):
        self.sim, self.world, self.out = sim, sim.world, out_dir
        self.config = sim.config
        self.end = float(self.config.time.end)
        self.cfl = float(self.config.time.cfl)
        self.dt_max = self.config.time.dt_max or np.inf
        self.fixed_dt = self.config.time.dt
        self.output = self.config.output
        self.schedule = Schedule(self.output, self.end)
        self.case_text = case_text
        self.case = case            # the validated case dict, kept in every checkpoint
        self.progress = Progress(self.end, progress and self.output.progress and
                                 self.world.is_root)
        self.watch = EnergyWatch(self.output.energy_warning, self.world.is_root,
                                 fault=self.output.energy_fault)
        self.load_work = LoadWork(self.world, sim.exact)
        self.particle_steps = 0
        self.element_steps = 0
        self.step_wall = 0.0
        self.step_dt = 0.0
        #: this process's first step, kept in the summary: with every kernel compiled by
        #: the warm-up (pmpm.kernels.warmup) it takes no longer than the others, and the
        #: rates count it (striker_on_fem_bar: 2.1 ms against 2.1 ms a step; before the
        #: FEM kernels were warmed it took 89 ms loading them, 21 s compiling them cold)
        self.first_step_s = None
        self.frame_index = 0
        self.failed = 0             # failed points (damage >= 1) at the last history row
        self.n_initial = self.world.sum(sim.particles.n)
        self.allowance = float(self.config.grid.lost_mass_fraction)
        self.n_elements = sim.n_elements
        names = sim.bodies.names
        stats = sim.body_stats()
        self.mass0 = initial_masses(self.config, names, stats, sim.decomposition.lost_mass)
        self.lost_seen = sim.lost
        self.wall_before = 0.0
        self.last_checkpoint = None
        self.restart = restart
        self.probes = Probes(self.world, self.output.probes, sim.particles, names,
                             restart.get("probes") if restart else None, sim.elements,
                             sim.exact) \
            if self.output.probes else None
        self.step_limit = ElementStepLimit(
            self.world, names, restart.get("element_step_limit") if restart else None) \
            if sim.elements else None
        if restart:
            self.restore(restart)

    def restore(self, scalars):
        """Continue the counters of the run a checkpoint came from (see save_checkpoint)."""
        self.particle_steps = scalars["particle_steps"]
        self.element_steps = scalars.get("element_steps", 0)
        self.failed = scalars.get("failed", 0)
        self.n_initial = scalars["n_initial"]
        self.step_wall = scalars.get("step_wall", 0.0)
        self.wall_before = scalars.get("wall_s", 0.0)
        self.last_checkpoint = scalars["step"]
        self.watch.restore(scalars.get("energy_watch"))
        if "body_mass0" in scalars:
            self.mass0 = converted_share(self.config,
                                         np.asarray(scalars["body_mass0"], np.float64))
        if self.world.is_root:
            self.load_work.restore(self.watch.load_work, scalars.get("load_work"))

    # -- run ---------------------------------------------------------------------
    def run(self, compile_s=0.0, baseline_rss=0):
        self.compile_s = compile_s
        self.baseline_rss = baseline_rss
        self.open_outputs()
        try:
            self.loop()
        except (SolverError, RunInterrupted):
            self.close_outputs()  # collective: every rank raised the same error
            raise

    def loop(self):
        if not self.restart:
            self.write_frame()
            self.write_history_row(0.0)
        self.started = clock.perf_counter()
        self.world.traffic.reset()          # what the steps send, not the set-up
        self.loop_first_step = self.sim.step_count
        self.progress.start(self.sim.time, self.particle_steps, self.element_steps)
        self.startup = since_process_start()    # frame 0 written, the first step next
        self.started_at = clock.time()          # against a launcher's clock (startup.py)
        dt = 0.0
        while self.sim.time < self.end * (1 - 1e-12):
            dt = self.next_dt()
            self.advance(dt)
            self.after_step(dt)
            self.stop_if_signalled(dt)
        self.finish(dt)

    def stop_if_signalled(self, dt):
        """After a step: when any rank has received SIGTERM or SIGINT, write a
        checkpoint and raise RunInterrupted on every rank (one MAX reduction a step)."""
        signum = self.world.max(received())
        if not signum:
            return
        sim = self.sim
        if self.last_checkpoint != sim.step_count:
            self.save_checkpoint(dt)
        last = checkpoint_path(self.out, self.last_checkpoint)
        raise RunInterrupted(
            f"interrupted by {signal_name(signum)} after step {sim.step_count} "
            f"(t = {sim.time:.6g}); checkpoint written: {last}; continue with --restart")

    def wall(self):
        """Seconds in the run loop so far, those of the runs before a restart included."""
        return self.wall_before + clock.perf_counter() - self.started

    def next_dt(self):
        sim = self.sim
        fastest = sim.fastest_speed()
        if self.fixed_dt is None:
            dt = min(self.cfl * sim.grid.h / fastest if fastest > 0 else self.dt_max,
                     self.dt_max)
        else:
            dt = self.fixed_step(fastest)
        self.step_dt = dt       # the step the run takes, before landing on a frame
        target = self.schedule.next_after(sim.time, 1e-12 * self.end) or self.end
        return min(dt, target - sim.time)

    def fixed_step(self, fastest):
        """time.dt, or a fault (on every rank: ``fastest`` is global) when it exceeds the
        stable step at cfl 1 of the last step's fastest wave plus point speed: a fixed
        step past it would blow up."""
        stable = self.sim.grid.h / fastest if fastest > 0 else np.inf
        if self.fixed_dt > stable * (1 + STEP_SLACK):
            raise SolverError(self.fault_message(
                f"the fixed step time.dt = {self.fixed_dt:g} exceeds the stable step "
                f"{stable:.4g} (at cfl 1, from the fastest wave plus point speed of the "
                f"last step); lower time.dt, or leave it out to follow time.cfl", self.fixed_dt))
        return self.fixed_dt

    def advance(self, dt):
        sim = self.sim
        n = self.world.sum(sim.particles.n)
        vectors = sim.load_vectors(sim.time + 0.5 * dt)
        power = self.load_work.power(sim, vectors) if self.config.loads else 0.0
        tick = clock.perf_counter()
        try:
            sim.advance(dt)
        except SolverError as err:
            raise SolverError(self.fault_message(err, dt)) from None
        if sim.lost != self.lost_seen:
            self.lost_seen = sim.lost
            self.check_lost(dt)
        took = clock.perf_counter() - tick
        self.step_wall += took
        self.particle_steps += n
        self.element_steps += self.n_elements
        if self.first_step_s is None:
            self.first_step_s = took
        if self.config.loads:          # the loads' work over the step (trapezoidal)
            self.load_work.add_step(dt, power, self.load_work.power(sim, vectors))

    def after_step(self, dt):
        sim, step = self.sim, self.sim.step_count
        if step % SORT_EVERY == 0:
            sim.sort_by_cell()
        decomposition = self.config.decomposition
        if step % decomposition.check_every == 0:
            sim.rebalance(decomposition.rebalance_threshold)
        at_frame = any(abs(sim.time - t) <= 1e-9 * self.end for t in self.schedule.times)
        if at_frame:
            self.write_frame()
        if at_frame or step % self.output.history_every == 0:
            self.write_history_row(dt)
        if self.checkpoint_due(at_frame):
            self.save_checkpoint(dt)
        self.progress.update(step, sim.time, self.step_dt, self.particle_steps,
                             self.watch.growth, sim.lost, self.failed,
                             elements=self.element_steps)

    def check_lost(self, dt):
        """A fault when some body has lost more than grid.lost_mass_fraction of its
        initial mass (a body of converted elements: its FEM body's) out of the grid box
        (the same on every rank: the sums are global)."""
        d = self.sim.decomposition
        over = np.flatnonzero(d.lost_mass > self.allowance * self.mass0 * (1 + 1e-12))
        if len(over) == 0:
            return
        b = over[0]
        name = self.sim.bodies.names[b]
        share = d.lost_mass[b] / self.mass0[b] if self.mass0[b] > 0 else 1.0
        err = (f"{int(d.lost_count[b])} particles of body '{name}' ({100 * share:.3g} % "
               f"of its mass) have left the grid box, more than grid.lost_mass_fraction = "
               f"{self.allowance:g} allows (raise it if bodies may leave the grid)")
        raise SolverError(self.fault_message(err, dt, taken=True))

    def fault_message(self, err, dt, taken=False):
        """``err`` with the step it happened in (``taken``: the step is already counted)
        and the last checkpoint."""
        sim = self.sim
        k, t = (sim.step_count, sim.time - dt) if taken else (sim.step_count + 1, sim.time)
        where = f"step {k} (t = {t:.6g} to {t + dt:.6g})"
        if self.last_checkpoint is None:
            return f"{where}: {err}; no checkpoint written"
        last = checkpoint_path(self.out, self.last_checkpoint)
        return f"{where}: {err}; last checkpoint: {last} (step {self.last_checkpoint})"

    def rate(self, column=1):
        """Particle-steps (``column`` 2: element-steps) per second of stepping, over every
        step of the run (the warm-up compiled the kernels before the first)."""
        count = (self.particle_steps, self.element_steps)[column - 1]
        return count / self.step_wall if self.step_wall > 0 else 0.0

    # -- outputs -----------------------------------------------------------------
    def open_outputs(self):
        names = self.sim.bodies.names
        r = self.restart
        self.writer = io.ParticleWriter(
            os.path.join(self.out, "particles.h5"), self.world.raw, self.case_text,
            {"body_names": names}, restart_frame=r["frame_index"] if r else None)
        self.frame_index = self.writer.n_frames
        self.element_writer = ElementWriter(
            os.path.join(self.out, "elements.h5"), self.sim.elements, names,
            self.world.raw, restart_frame=r["frame_index"] if r else None,
            precision=self.output.precision) if self.sim.elements else None
        self.bodies_xdmf = BodiesXdmf(os.path.join(self.out, "bodies.xdmf"))
        self.probe_writer = ProbeWriter(
            self.out, self.probes.names, PROBE_COLUMNS,
            restart_step=r["step"] if r else None) \
            if self.probes and self.world.is_root else None
        log = self.sim.force_log
        self.forces_writer = ForcesWriter(
            self.out, log.columns(), restart_step=r["step"] if r else None) \
            if log and self.world.is_root else None
        self.history = io.HistoryWriter(
            os.path.join(self.out, "history.csv"), names,
            restart_step=r["step"] if r else None) if self.world.is_root else None

    def write_frame(self):
        p = self.sim.particles
        displacement = Deferred(lambda: p.x - p.x0, p.x.shape, np.float64)
        columns = {"x": p.x, "displacement": displacement, "v": p.v, "stress": p.stress,
                   "eps_p": p.eps_p,
                   "density": p.rho, "mass": p.mass, "body": p.body, "id": p.id,
                   "temp": p.temp, "e_int": p.e_int, "damage": p.damage}
        if self.sim.points.apic:
            columns["affine"] = p.affine
        self.writer.write_frame(self.sim.time, self.sim.step_count,
                                deferred_frame_columns(columns, self.output.precision))
        if self.element_writer:
            self.element_writer.write_frame(self.sim.time, self.sim.step_count)
            if self.world.is_root:
                self.bodies_xdmf.write(self.writer, self.element_writer)
        self.frame_index += 1

    def write_history_row(self, dt):
        e = self.sim.energies()
        if not all(np.isfinite(value) for value in e.values()):
            raise SolverError(
                f"step {self.sim.step_count} (t = {self.sim.time:.6g}): the energies are "
                f"not finite (kinetic {e['kinetic']:.3g}, internal {e['internal']:.3g}): "
                f"a material value, load or velocity overflows double precision")
        log = self.sim.force_log
        forces = log.take_row(self.sim.time) if log else None
        e["dissipated"] = log.dissipated if log else float("nan")
        self.watch.observe(self.sim.time, e, self.sim.gravitational_potential(
            self.config.gravity), self.load_work.total())
        fault = self.watch.fault_line(self.sim.time)
        if fault:
            raise SolverError(self.fault_message(fault, dt, taken=True))
        stats = self.sim.body_stats()
        self.failed = sum(s["n_failed"] for s in stats.values())
        if self.step_limit:
            self.step_limit.observe(self.sim.elements, self.sim.time, self.sim.step_count,
                                    self.step_dt)
        if self.history is not None:
            rows = {name: s["centroid"] + s["velocity"] + body_energies(s)
                    for name, s in stats.items()}
            self.history.row(self.sim.step_count, self.sim.time, dt,
                             (e["kinetic"], e["internal"], e["total"], e["dissipated"]), rows)
        if forces is not None:
            if self.forces_writer:
                self.forces_writer.row(self.sim.step_count, self.sim.time, forces)
        if self.probes:
            values = self.probes.sample(self.sim.particles)
            if self.probe_writer:
                self.probe_writer.rows(self.sim.step_count, self.sim.time, values)

    def checkpoint_due(self, at_frame):
        if not self.output.checkpoints:
            return False
        every = self.output.checkpoint_every
        return (self.sim.step_count % every == 0) if every > 0 else at_frame

    def save_checkpoint(self, dt):
        sim = self.sim
        scalars = {"time": sim.time, "step": sim.step_count, "dt": dt,
                   "particle_steps": self.particle_steps, "n_initial": self.n_initial,
                   "element_steps": self.element_steps, "failed": self.failed,
                   "frame_index": self.frame_index, "step_wall": self.step_wall,
                   "wall_s": self.wall(), "energy_watch": self.watch.state(),
                   "body_mass0": self.mass0.tolist(),
                   "probes": self.probes.state() if self.probes else {},
                   "load_work": self.load_work.state(),
                   "element_step_limit": self.step_limit.state() if self.step_limit else None,
                   **sim.restart_state()}
        case = None if self.case is None else {"text": self.case_text, "case": self.case}
        io.save_checkpoint(self.out, self.world.raw, scalars, sim.particles.columns(),
                           case=case, groups=sim.checkpoint_groups())
        self.last_checkpoint = sim.step_count

    def finish(self, dt):
        """Final frame, a checkpoint of the final state (so that a run cut short by
        ``time.end`` can be continued with a later end), summary; close the files."""
        sim = self.sim
        if self.frame_index == 0 or not any(abs(sim.time - t) <= 1e-9 * self.end
                                            for t in self.schedule.times):
            self.write_frame()
        self.wall_s = self.wall()
        if self.output.checkpoints and self.last_checkpoint != sim.step_count:
            self.save_checkpoint(dt)
        summary = self.summary()
        self.close_outputs(summary)
        if self.world.is_root:
            io.write_summary(os.path.join(self.out, "summary.json"), summary)

    def close_outputs(self, summary=None):
        self.writer.close(summary)
        if self.element_writer:
            self.element_writer.close()
        if self.history is not None:
            self.history.close()
        if getattr(self, "probe_writer", None):
            self.probe_writer.close()
        if getattr(self, "forces_writer", None):
            self.forces_writer.close()

    def summary(self):
        sim = self.sim
        bodies = self.body_summary()
        return {
            "case": self.config.title,
            "ranks": self.world.size,
            "n_particles": {"initial": self.n_initial,
                            "final": self.world.sum(sim.particles.n)},
            "n_steps": sim.step_count, "t_end": sim.time,
            "wall_s": self.wall_s, "step_wall_s": self.step_wall,
            "compile_s": self.compile_s, "first_step_s": self.first_step_s or 0.0,
            "startup_s": self.startup_summary(),
            "particle_steps_per_s": self.rate(),
            "particle_steps_per_s_per_rank": self.rate() / self.world.size,
            "particles_lost": int(sim.lost),
            "n_failed": sum(body["n_failed"] for body in bodies.values()),
            "slabs": {"axis": "xyz"[sim.slabs.axis], "bounds": sim.slabs.bounds.tolist(),
                      "imbalance": sim.imbalance()},
            "windows": self.window_summary(),
            "energy": sim.energies(),
            "energy_balance": self.watch.summary(),
            "memory": memory_summary(self.world, self.baseline_rss, self.n_initial,
                                     self.sim.elements.n_elements_total
                                     if self.sim.elements else 0),
            "bodies": bodies,
            **self.element_summary(),
            **self.sim.contact_summary(),
            "communication": self.communication_summary(),
        }

    def startup_summary(self):
        """Seconds from process start to the first step of this process's loop (wall, CPU
        and waiting for a core: pmpm.solver.startup), the slowest rank's (collective):
        imports, MPI, kernels, set-up, frame 0; ``at``: rank 0's clock then."""
        mine = getattr(self, "startup", {})
        summary = {key: self.world.max(-1.0 if mine.get(key) is None else mine[key])
                   for key in ("wall", "cpu", "queued", "wall_less_queued")}
        summary["at"] = getattr(self, "started_at", None)
        return summary

    def communication_summary(self):
        """What a rank sent per step of this process's loop (the frames, history rows and
        checkpoints written meanwhile included), per kind (neighbour messages, collectives,
        all-to-all migration): the mean over the ranks and the largest (collective)."""
        traffic = self.world.traffic
        steps = max(self.sim.step_count - getattr(self, "loop_first_step", 0), 1)
        mine = [traffic.messages[k] / steps for k in traffic.KINDS] + \
               [traffic.bytes[k] / steps for k in traffic.KINDS]
        every = np.array(self.world.allgather(mine))
        n = len(traffic.KINDS)
        return {kind: {"messages_per_step": {"mean": float(every[:, k].mean()),
                                             "largest": float(every[:, k].max())},
                       "bytes_per_step": {"mean": float(every[:, n + k].mean()),
                                          "largest": float(every[:, n + k].max())}}
                for k, kind in enumerate(traffic.KINDS)}

    def element_summary(self):
        """With FEM bodies: their element count, element-steps per second of stepping
        (the whole step's wall time, particles included, every step), each rank's
        elements at the end, what an element of each FEM body weighs in the slabs'
        balance, in particle-steps (solver.work_weights), and the element that had the
        shortest stable step at a history row (solver.step_limit)."""
        if not self.sim.elements:
            return {}
        rate = self.rate(column=2)
        per_rank = self.world.allgather(self.sim.elements.n_elements)
        weights = self.sim.elements.weight_of_body
        return {"n_elements": self.n_elements, "element_steps_per_s": rate,
                "elements_per_rank": [int(n) for n in per_rank],
                "element_weights": {self.sim.bodies.names[b]: float(weights[b])
                                    for b in self.sim.elements.body_indices},
                "element_step_limit": self.step_limit.summary()}

    def window_summary(self):
        """Each refined window's final box (mm), ratio and particle count."""
        grid = self.sim.grid
        counts = self.sim.window_counts()
        return [{"min": (grid.origin + w.lo * grid.h).tolist(),
                 "max": (grid.origin + w.hi * grid.h).tolist(), "ratio": w.ratio,
                 "n_particles": int(counts[1 + i])} for i, w in enumerate(self.sim.windows)]

    def body_summary(self):
        stats = self.sim.body_stats()
        d = self.sim.decomposition
        for b, body in enumerate(stats.values()):
            body["lost_particles"] = int(d.lost_count[b])
            body["lost_mass"] = float(d.lost_mass[b])
            if body["n_particles"] == 0 and not body.get("n_elements"):
                # every particle left the grid: no box to give
                body["bbox_min"] = list(body["centroid"])
                body["bbox_max"] = list(body["centroid"])
        return stats


def initial_masses(config, names, stats, lost):
    """Per body the mass the lost-mass allowance is a share of: its mass at the start
    (with what already left), and for a body that holds an FEM body's converted elements
    (``born_of``, empty at the start) its FEM body's."""
    return converted_share(config, np.array([stats[name]["mass"] for name in names]) + lost)


def converted_share(config, mass0):
    """``mass0`` with each body of converted elements given its FEM body's (also for a
    checkpoint written before it was)."""
    into = converted_into(config.bodies)
    for b in np.flatnonzero(into >= 0):
        mass0[into[b]] = mass0[b]
    return mass0
