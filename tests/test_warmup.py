"""Every kernel a case uses compiles (or loads) in the warm-up, before the step loop
(issues 25 and 26): after ``warm_up(**kernels_of(config))`` the first steps of an FEM case
add no signature to any of pmpm's Numba dispatchers. Numba compiles one specialisation
per argument-type signature, so a warm-up call with another dtype, layout or None for an
array would leave the step compiling a second variant: counting signatures catches that
where timing would not.

Each case runs in a fresh interpreter (tests/warmhelp.py): in this one, earlier tests
have compiled the kernels already and nothing new could show."""
import json
import os
import subprocess
import sys

import pytest

from runhelp import CASES, MPI_ENV, ROOT
from warmhelp import gained_in_steps

HELPER = os.path.join(ROOT, "tests", "warmhelp.py")
#: surface contact (ICFEMP), grid coupling (CFEMP), node-to-surface contact; each with
#: a kernel of its own that must have run in the steps
FEM_CASES = {"striker_on_fem_bar.yaml": "pmpm.kernels.surface_contact.find_pairs",
             "fem_grid_bounce.yaml": "pmpm.kernels.fem_grid.contact_velocity_changes",
             "fem_block_on_fem_plate.yaml": "pmpm.kernels.node_contact.find_node_pairs"}


def steps_in_fresh_process(case, bare=False):
    env = dict(os.environ, **MPI_ENV, PYTHONPATH=ROOT)
    done = subprocess.run([sys.executable, HELPER, os.path.join(CASES, case)]
                          + (["--bare"] if bare else []),
                          capture_output=True, text=True, timeout=600, env=env, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("case", sorted(FEM_CASES))
def test_fem_steps_compile_nothing_after_the_warm_up(case):
    result = steps_in_fresh_process(case)
    assert result["gained"] == [], f"compiled in the steps of {case}: {result['gained']}"
    for used in ("pmpm.fem.elements.element_forces", "pmpm.kernels.forces.face_zone",
                 FEM_CASES[case]):
        assert used in result["compiled"], f"{case}: {used} never ran"


def test_without_the_fem_warm_up_the_first_step_compiles():
    """The control: with the MPM warm-up alone the step gains the FEM kernels."""
    gained = steps_in_fresh_process("striker_on_fem_bar.yaml", bare=True)["gained"]
    for kernel in ("pmpm.fem.elements.element_forces",
                   "pmpm.kernels.surface_contact.find_pairs",
                   "pmpm.kernels.forces.face_zone"):
        assert kernel in gained


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("case", ["striker_on_fem_bar.yaml", "fem_block_on_fem_plate.yaml"])
def test_fem_steps_compile_nothing_after_the_warm_up_on_ranks(case):
    """On 2 ranks, whose halo exchanges call the segment kernels 1 rank skips. In
    process: the session's warm_up_defaults has taken the linear shape's kernels
    already, so this checks that the 2-rank paths pass no other argument types."""
    from mpi4py import MPI

    from pmpm.comm import World
    gained, _ = gained_in_steps(os.path.join(CASES, case), World(MPI.COMM_WORLD))
    assert gained == []
