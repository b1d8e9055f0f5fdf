"""Progress lines on rank 0: on a terminal about once a second, otherwise every 5 %."""
import sys
import time as clock


class Progress:
    def __init__(self, end_time, enabled=True, stream=None):
        self.end = end_time
        self.stream = stream or sys.stdout
        self.enabled = enabled
        self.tty = self.stream.isatty()
        self.started = clock.perf_counter()
        self.last_print = 0.0
        self.next_fraction = 0.05

    def update(self, step, t, dt, rate):
        if not self.enabled:
            return
        fraction = t / self.end if self.end > 0 else 1.0
        now = clock.perf_counter()
        if self.tty and now - self.last_print < 1.0 and fraction < 1.0:
            return
        if not self.tty and fraction < self.next_fraction:
            return
        while self.next_fraction <= fraction:
            self.next_fraction += 0.05
        self.last_print = now
        elapsed = now - self.started
        eta = elapsed * (1.0 - fraction) / fraction if fraction > 0 else float("nan")
        line = (f"step {step:7d}  t {t:.4e}  dt {dt:.3e}  {100 * fraction:5.1f}%  "
                f"{rate / 1e6:6.2f} M particle-steps/s  ETA {eta:7.1f} s")
        end = "\r" if self.tty and fraction < 1.0 else "\n"
        self.stream.write(line + end)
        self.stream.flush()
