"""Compile (or load) the step's kernels once before any test, for the hats and for the
default shape functions (with the APIC transfer's variants), so that the first command-line test on a fresh clone does not
spend its time limit in Numba."""
from pmpm.case.schema import GRID
from pmpm.kernels.shape import LINEAR, SHAPE_CODES
from pmpm.kernels.warmup import warm_up


def pytest_sessionstart(session):
    warm_up(LINEAR)
    warm_up(SHAPE_CODES[GRID["shape_functions"].default], apic=True)
