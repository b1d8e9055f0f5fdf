"""Run pmpm's command line from tests, on 1 or 2 ranks."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUNS = os.path.join(ROOT, "runs")
CASES = os.path.join(ROOT, "tests", "cases")
MPI_ENV = {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}


def run_pmpm(case, out, ranks=1, sets=(), timeout=900, check=True, extra=()):
    """Run ``case`` into ``out`` (overwriting, or continuing with ``extra=["--restart"]``);
    returns the CompletedProcess."""
    cmd = [sys.executable, "-m", "pmpm", case, "--out", str(out), "--quiet"]
    cmd += list(extra) if "--restart" in extra else ["--force"] + list(extra)
    for item in sets:
        cmd += ["--set", item]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe"] + cmd
    env = dict(os.environ, **MPI_ENV)
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env,
                          cwd=ROOT)
    if check and done.returncode != 0:
        raise AssertionError(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr}")
    return done


def set_up(case, overrides=(), world=None):
    """The Simulation of ``case`` (a path) set up in this process: one rank unless
    ``world`` (a pmpm.comm.World) says otherwise."""
    from pmpm.case import fill_body
    from pmpm.case.loader import load_config
    from pmpm.comm import World
    from pmpm.solver.simulation import Simulation
    config = load_config(case, list(overrides))
    if world is None:
        from mpi4py import MPI
        world = World(MPI.COMM_SELF)
    return Simulation.from_config(world, config, os.path.dirname(case), fill_body)
