"""Which element holds the step (issue 24): at every history row, the FEM element with
the shortest stable step in the last force pass, over all ranks; summary.json keeps the
shortest over the run (``element_step_limit``), so that a run whose step collapses names
the element (its body, its number in the body, where it was) and when.

The choice is the same on any number of ranks: the largest stable rate, and of equal
rates the lowest global element id."""
import math


class ElementStepLimit:
    """The run's shortest element step so far (``worst``: a summary dict, or None)."""

    def __init__(self, world, names, state=None):
        self.world, self.names = world, names
        self.worst = dict(state) if state else None

    def observe(self, elements, time, step, dt):
        """Take this history row's stiffest element (collective)."""
        rows = [row for row in self.world.allgather(elements.stiffest_element())
                if row is not None]
        if not rows:
            return
        rate, _, body, number, centroid = max(rows, key=lambda r: (r[0], -r[1]))
        if rate <= 0.0 or (self.worst is not None and rate <= self.worst["rate"]):
            return
        self.worst = {"stable_step": 1.0 / rate if math.isfinite(rate) else 0.0,
                      "rate": rate if math.isfinite(rate) else 1e300,
                      "time": time, "step": step, "run_dt": dt, "body": self.names[body],
                      "element": number, "centroid": [float(c) for c in centroid]}

    def summary(self):
        """``element_step_limit`` of summary.json ({} before any FEM force pass):
        ``stable_step`` the element's stable step at cfl 1 (0: inverted), ``run_dt``
        the run's step at that history row (time.cfl times the shortest stable step of
        elements and particles, or time.dt; before any landing on a frame time),
        ``time`` and ``step`` of the row, ``body``, ``element`` (its number within the
        body, as the fault messages give it) and its ``centroid``."""
        if self.worst is None:
            return {}
        return {k: v for k, v in self.worst.items() if k != "rate"}

    def state(self):
        """What a checkpoint keeps (None: nothing yet)."""
        return self.worst
