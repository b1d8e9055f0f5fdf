"""Compile (or load) the step's kernels once before any test, so that the first
command-line test on a fresh clone does not spend its time limit in Numba."""
from pmpm.kernels.warmup import warm_up


def pytest_sessionstart(session):
    warm_up()
