"""Errors the solver raises on every rank at once."""


class SolverError(RuntimeError):
    """A fault during the run (NaN, failed constitutive update, non-positive density),
    raised collectively so every rank stops with the same message.

    Likely causes: a time step too large for the material (lower ``time.cfl``), an
    unphysical material constant, or a body leaving the grid through a fixed face.
    """


class SetupError(ValueError):
    """Input that only turns out wrong once particles exist; ``problems`` names keys."""

    def __init__(self, problems):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))
