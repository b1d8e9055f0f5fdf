"""Progress lines on rank 0: on a terminal about once a second, otherwise every 5 %;
rate and ETA over the last ``WINDOW_S`` seconds of wall time."""
import collections
import os
import sys
import threading
import time as clock

#: Set by MPI launchers (Open MPI, MPICH/Hydra, PMIx) in the ranks they start.
LAUNCHER_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK")


def on_terminal(stream):
    """True when ``stream`` is a terminal a person watches. Under mpirun a rank's stdout
    is a pseudo-terminal even when mpirun's own output goes to a file or a pipe, so a
    launched rank counts as not on a terminal."""
    launched = any(name in os.environ for name in LAUNCHER_VARIABLES)
    return stream.isatty() and not launched


#: Wall seconds of the recent window that the rate and the ETA are measured over.
WINDOW_S = 20.0


class RecentRate:
    """Simulated time, particle-steps and element-steps per wall second over the last
    ``WINDOW_S`` seconds (or since the start, when shorter): a run whose steps slow down
    (contact spreads, particles split, a window refines) shows the rate and the ETA it
    has now, not its average since the start."""

    def __init__(self, now, t, work, elements=0):
        self.samples = collections.deque([(now, t, work, elements)])

    def add(self, now, t, work, elements=0):
        if now - self.samples[-1][0] >= WINDOW_S / 40:
            self.samples.append((now, t, work, elements))
        while len(self.samples) > 2 and now - self.samples[1][0] >= WINDOW_S:
            self.samples.popleft()

    def rates(self, now, t, work, elements=0):
        """(simulated time, particle-steps, element-steps) per wall second over the
        window."""
        then, t0, work0, elements0 = self.samples[0]
        wall = now - then
        if wall <= 0:
            return 0.0, 0.0, 0.0
        return (t - t0) / wall, (work - work0) / wall, (elements - elements0) / wall


class Progress:
    def __init__(self, end_time, enabled=True, stream=None):
        self.end = end_time
        self.stream = stream or sys.stdout
        self.enabled = enabled
        self.tty = on_terminal(self.stream)
        self.last_print = 0.0
        self.start(0.0, 0)  # next_mark: the next multiple of 5 % to report off a terminal

    def start(self, t, work, elements=0):
        """The step loop begins (at ``t``, after ``work`` particle-steps and ``elements``
        element-steps: a restart's); the next line is due at the first 5 % mark past
        ``t``, not at once with a rate measured over no steps."""
        self.started = clock.perf_counter()
        self.recent = RecentRate(self.started, t, work, elements)
        fraction = t / self.end if self.end > 0 else 0.0
        self.next_mark = int(fraction * 20 + 1e-9) + 1

    def update(self, step, t, dt, work, energy_growth=0.0, lost=0, failed=0, elements=0):
        """After a step: ``dt`` the step the run takes (not one shortened to land on a
        frame), ``work`` the particle-steps done so far, ``energy_growth`` the current
        energy balance (fraction), ``lost`` the particles that left the grid, ``failed``
        the failed points (damage >= 1, particles and elements, all ranks) at the last
        history row, ``elements`` the element-steps done so far (shown when the run has
        FEM bodies: a mesh's run is measured by them, not by its few particles)."""
        if not self.enabled:
            return
        fraction = t / self.end if self.end > 0 else 1.0
        now = clock.perf_counter()
        self.recent.add(now, t, work, elements)
        if self.tty and now - self.last_print < 1.0 and fraction < 1.0:
            return
        if not self.tty and fraction < self.next_mark / 20 - 1e-9:
            return
        while self.next_mark / 20 - 1e-9 <= fraction:
            self.next_mark += 1
        self.last_print = now
        speed, rate, element_rate = self.recent.rates(now, t, work, elements)
        eta = (self.end - t) / speed if speed > 0 else float("nan")
        line = (f"step {step:7d}  t {t:.4e}  dt {dt:.3e}  {100 * fraction:5.1f}%  "
                f"{rate / 1e6:6.2f} M particle-steps/s  "
                + (f"{element_rate / 1e6:6.2f} M element-steps/s  " if elements else "")
                + f"energy {100 * energy_growth:+6.2f}%  "
                f"ETA {eta:7.1f} s" + (f"  lost {lost}" if lost else "")
                + (f"  failed {failed}" if failed else ""))
        end = "\r" if self.tty and fraction < 1.0 else "\n"
        self.stream.write(line + end)
        self.stream.flush()


class SlowNotice:
    """Context manager: when the block is still running ``after`` seconds in, print
    ``message`` (once, from a timer thread), and when it ends the seconds it took, so
    that a first run's kernel compile (minutes after an install or an edit; a second
    later) is announced instead of a silent wait. Prints nothing when not ``enabled``
    or when the block is quick."""

    def __init__(self, message, enabled=True, after=2.0, stream=None):
        self.message, self.enabled, self.after = message, enabled, after
        self.stream = stream or sys.stdout
        self.said = False

    def __enter__(self):
        self.started = clock.perf_counter()
        if self.enabled:
            self.timer = threading.Timer(self.after, self._say)
            self.timer.daemon = True
            self.timer.start()
        return self

    def _say(self):
        self.said = True
        self.stream.write(f"pmpm: {self.message} ...\n")
        self.stream.flush()

    def __exit__(self, *exc):
        if self.enabled:
            self.timer.cancel()
            if self.said:
                took = clock.perf_counter() - self.started
                self.stream.write(f"pmpm: done in {took:.0f} s\n")
                self.stream.flush()
        return False
