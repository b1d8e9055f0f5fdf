"""Progress lines on rank 0: on a terminal about once a second, otherwise every 5 %."""
import os
import sys
import time as clock

#: Set by MPI launchers (Open MPI, MPICH/Hydra, PMIx) in the ranks they start.
LAUNCHER_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK")


def on_terminal(stream):
    """True when ``stream`` is a terminal a person watches. Under mpirun a rank's stdout
    is a pseudo-terminal even when mpirun's own output goes to a file or a pipe, so a
    launched rank counts as not on a terminal."""
    launched = any(name in os.environ for name in LAUNCHER_VARIABLES)
    return stream.isatty() and not launched


class Progress:
    def __init__(self, end_time, enabled=True, stream=None):
        self.end = end_time
        self.stream = stream or sys.stdout
        self.enabled = enabled
        self.tty = on_terminal(self.stream)
        self.started = clock.perf_counter()
        self.last_print = 0.0
        self.next_mark = 1  # next multiple of 5 % to report when not on a terminal

    def update(self, step, t, dt, rate, energy_growth=0.0, lost=0):
        if not self.enabled:
            return
        fraction = t / self.end if self.end > 0 else 1.0
        now = clock.perf_counter()
        if self.tty and now - self.last_print < 1.0 and fraction < 1.0:
            return
        if not self.tty and fraction < self.next_mark / 20 - 1e-9:
            return
        while self.next_mark / 20 - 1e-9 <= fraction:
            self.next_mark += 1
        self.last_print = now
        elapsed = now - self.started
        eta = elapsed * (1.0 - fraction) / fraction if fraction > 0 else float("nan")
        line = (f"step {step:7d}  t {t:.4e}  dt {dt:.3e}  {100 * fraction:5.1f}%  "
                f"{rate / 1e6:6.2f} M particle-steps/s  energy {100 * energy_growth:+6.2f}%  "
                f"ETA {eta:7.1f} s" + (f"  lost {lost}" if lost else ""))
        end = "\r" if self.tty and fraction < 1.0 else "\n"
        self.stream.write(line + end)
        self.stream.flush()
