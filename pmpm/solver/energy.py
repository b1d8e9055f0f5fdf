"""The energy watch: how far the run's energy balance has drifted since the start.

The balance is kinetic + internal energy + what contact and friction have dissipated
(history.csv's ``dissipated``) + gravitational potential (-sum m g.x) less the work the
loads have done; its growth is measured against the energy the run was given
(initial kinetic + internal, plus what gravity and the loads supplied). Where nothing
else does work (no rigid body, no fixed face pushing, no contact with a rigid body), an
explicit step that conserves energy keeps the balance constant; growth is numerical
energy gained, the usual sign of a step or a feature used outside its range."""
import sys

import numpy as np

from ..kernels import exact_sum
from .observe import exact_totals

CAUSES = ("particles crossing cells with linear shape functions, worst where the "
          "crossing material is highly stressed, as behind a strong shock (use "
          "grid.shape_functions: bspline or gimp, or lower time.cfl), contact that keeps "
          "pushing after bodies part; rigid "
          "bodies and fixed faces also do work the balance does not count")


LOSS_CAUSES = ("contact between bodies beyond its friction (history.csv's dissipated "
               "holds the friction work; see docs/validation/energy_channels.md), "
               "time.pic or APIC damping (a PIC "
               "share takes kinetic energy at every transfer), a coarse grid under large rotations, particles that left the "
               "grid, elements or particles removed, fixed faces or rigid bodies "
               "absorbing an impact, a body stretched and swept over several cells at a "
               "long step (time.cfl above 0.5, auto's 0.8 included: try time.cfl 0.5; "
               "docs/validation/defaults.md)")


class EnergyWatch:
    """Follows the growth of the energy balance since the start, relative to the energy
    the run was given: the initial kinetic + internal energy plus the largest energy
    that gravity and the loads have supplied so far (so that a body at rest that falls
    or is loaded has a scale too).

    Parameters
    ----------
    threshold : float   growth (fraction) above which one warning is printed; 0: never
    speak : bool   whether this rank prints (rank 0)
    fault : float   growth above which the run stops (:meth:`fault_line`); 0: never
    """

    def __init__(self, threshold, speak, stream=None, fault=0.0):
        self.threshold, self.speak, self.fault = threshold, speak, fault
        self.stream = stream or sys.stderr
        self.start = None                 # (kinetic + internal, potential) at the start
        self.supplied = 0.0
        self.growth = 0.0
        self.largest, self.largest_at = 0.0, 0.0
        self.load_work = 0.0
        self.warned = False
        self.loss, self.largest_loss, self.largest_loss_at = 0.0, 0.0, 0.0
        self.warned_loss = False

    def observe(self, time, energy, potential, load_work):
        """Take the energies of a history row (``energy``: kinetic, internal, total and,
        if measured, what contact, friction and the faces have dissipated so far), the
        gravitational potential and the work the loads have done so far (all over all
        ranks); returns the growth since the start. A loss is followed too
        (:meth:`observe_loss`)."""
        dissipated = energy.get("dissipated", 0.0)
        dissipated = dissipated if np.isfinite(dissipated) else 0.0
        if self.start is None:
            self.start = (energy["total"] + dissipated, potential)
        given, potential0 = self.start
        self.load_work = load_work
        external = potential0 - potential + load_work     # the energy supplied so far
        self.supplied = max(self.supplied, external)
        drift = energy["total"] + dissipated - given - external
        self.growth = drift / max(given + self.supplied, 1e-300)
        if self.growth > self.largest:
            self.largest, self.largest_at = self.growth, time
        if self.threshold > 0 and self.growth > self.threshold and not self.warned:
            self.warned = True
            self.warn(time)
        self.observe_loss(time, drift, given + self.supplied)
        return self.growth

    def observe_loss(self, time, drift, scale):
        """The energy the balance has lost, as a fraction of what the run was given.
        Plastic work, heat and the elements' hourglass energy stay in ``internal``, so
        they are no loss; what is lost went to a channel the balance does not hold
        (:data:`LOSS_CAUSES`). Warned once past the threshold, as a gain is."""
        self.loss = -drift / max(scale, 1e-300)
        if self.loss > self.largest_loss:
            self.largest_loss, self.largest_loss_at = self.loss, time
        if self.threshold > 0 and self.loss > self.threshold and not self.warned_loss:
            self.warned_loss = True
            if self.speak:
                self.stream.write(
                    f"pmpm: warning: the energy balance has lost {100 * self.loss:.1f} % by "
                    f"t = {time:.6g} (output.energy_warning: {self.threshold:g}; plastic "
                    f"work and hourglass energy are not losses, they stay in the internal "
                    f"energy); usual causes: {LOSS_CAUSES}\n")
                self.stream.flush()

    def warn(self, time):
        if self.speak:
            self.stream.write(
                f"pmpm: warning: the energy balance has grown {100 * self.growth:.1f} % by "
                f"t = {time:.6g} (output.energy_warning: {self.threshold:g}); usual causes: "
                f"{CAUSES}\n")
            self.stream.flush()

    def fault_line(self, time):
        """The fault when the growth has passed ``fault`` (the same on every rank: the
        energies are global sums), or None."""
        if not (self.fault > 0 and self.growth > self.fault):
            return None
        return (f"the energy balance has grown {100 * self.growth:.4g} % since the start "
                f"(by t = {time:.6g}), more than output.energy_fault = {self.fault:g} "
                f"allows: the answer is numerical energy, not physics; usual causes: "
                f"{CAUSES}; an FEM body's hourglass coefficient")

    def summary(self):
        return {"growth": self.growth, "largest_growth": self.largest,
                "largest_growth_at": self.largest_at, "threshold": self.threshold,
                "fault": self.fault,
                "warned": self.warned, "loss": self.loss,
                "largest_loss": self.largest_loss, "largest_loss_at": self.largest_loss_at,
                "warned_loss": self.warned_loss}

    def state(self):
        return {"start": list(self.start) if self.start else None,
                "supplied": self.supplied, "largest": self.largest,
                "largest_at": self.largest_at, "load_work": self.load_work,
                "warned": self.warned, "largest_loss": self.largest_loss,
                "largest_loss_at": self.largest_loss_at, "warned_loss": self.warned_loss,
                "growth": self.growth, "loss": self.loss}

    def restore(self, state):
        if state:
            self.start = tuple(state["start"]) if state["start"] else None
            self.supplied = state["supplied"]
            self.largest, self.largest_at = state["largest"], state["largest_at"]
            self.load_work, self.warned = state["load_work"], state["warned"]
            self.largest_loss = state.get("largest_loss", 0.0)
            self.largest_loss_at = state.get("largest_loss_at", 0.0)
            self.warned_loss = state.get("warned_loss", False)
            self.growth = state.get("growth", 0.0)     # as the last row left them, so
            self.loss = state.get("loss", 0.0)         # a restart's first line says it


def load_power(particles, load_vectors):
    """sum over loaded particles of scale * load . v (this rank's part)."""
    loaded = particles.load >= 0
    if not loaded.any():
        return 0.0
    p = particles
    forces = p.load_scale[loaded, None] * load_vectors[p.load[loaded]]
    return float(np.einsum("ij,ij->", forces, p.v[loaded]))


def load_power_terms(load, scale, v, load_vectors):
    """Per loaded point (``load`` >= 0) its scale * load . v, elementwise (the same bits
    on any rank: no BLAS), for the exact sums."""
    loaded = load >= 0
    force = scale[loaded, None] * load_vectors[load[loaded]]
    u = v[loaded]
    return force[:, 0] * u[:, 0] + force[:, 1] * u[:, 1] + force[:, 2] * u[:, 2]


class LoadWork:
    """The work the loads have done so far, the trapezoidal rule over each step of the
    power before and after it (the run loop's). Each rank sums its points' part; with
    ``exact`` (grid.exact_sums) each point's half-step work is a term of an exact
    accumulator (pmpm.kernels.exact_sum), so the total has the same bits on any rank
    count, else a float per rank summed over the ranks at each history row."""

    def __init__(self, world, exact):
        self.world, self.exact = world, exact
        self.local = exact_sum.zeros(1) if exact else 0.0

    def power(self, sim, vectors):
        """This rank's power of the loads at ``vectors``: a float, or with exact sums the
        terms of its points (pmpm.solver.simulation.Simulation.load_power_terms)."""
        return sim.load_power_terms(vectors) if self.exact else sim.load_power(vectors)

    def add_step(self, dt, before, after):
        """Add a step's work from the powers :meth:`power` gave before and after it."""
        if self.exact:
            exact_sum.add_terms(self.local, 0, 0.5 * dt * before)
            exact_sum.add_terms(self.local, 0, 0.5 * dt * after)
        else:
            self.local += 0.5 * dt * (before + after)

    def total(self):
        """The work over all ranks (collective)."""
        if self.exact:
            return float(exact_totals(self.world, [self.local])[0][0])
        return self.world.sum(self.local)

    def state(self):
        """With exact sums the accumulator's bins summed over the ranks (collective), so
        that a restart continues the exact sum; else None (the history row's total, in
        the energy watch's state, is what a restart takes)."""
        if not self.exact:
            return None
        exact_sum.carry_all(self.local)
        return self.world.sum(self.local).tolist()

    def restore(self, work, bins=None):
        """Continue from a checkpoint (on one rank: rank 0): its exact sum's ``bins``
        (:meth:`state`) where it has them, else its ``work`` so far."""
        if not self.exact:
            self.local = work
        elif bins is not None:
            self.local[:] = np.asarray(bins, np.int64)
        else:
            exact_sum.add_terms(self.local, 0, np.array([float(work)]))
