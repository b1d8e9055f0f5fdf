"""Each rank's busy time in the step loop: the CPU seconds a rank spent in its steps
(``Simulation.advance``) outside communication, so that the imbalance between ranks can
be measured on a shared machine, where wall times follow the other jobs' load (a rank
that waits for its neighbour spins inside MPI: that time is communication, left out).

Communication is every call of a pmpm.comm function (and of a ``World`` method) made
during a step, timed from outside: the functions are wrapped where the solver's modules
imported them; no pmpm code is changed.

Run under mpirun with the checkout to measure first:

    mpirun -n 2 TREE/.venv/bin/python scripts/busy_time.py TREE OUT.json CASE.yaml [pmpm args]

OUT.json gets, per rank, ``busy_cpu_s``, ``comm_cpu_s``, ``step_wall_s`` and ``steps``.
"""
import functools
import json
import sys
import time

TIMES = {"busy_cpu_s": 0.0, "comm_cpu_s": 0.0, "step_wall_s": 0.0, "steps": 0}
STATE = {"in_step": False, "depth": 0}


def timed_comm(function):
    """``function`` with its CPU time added to the communication while a step runs
    (outermost call only: a comm function that calls another counts once)."""
    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        if not STATE["in_step"] or STATE["depth"]:
            return function(*args, **kwargs)
        STATE["depth"] += 1
        start = time.process_time()
        try:
            return function(*args, **kwargs)
        finally:
            TIMES["comm_cpu_s"] += time.process_time() - start
            STATE["depth"] -= 1
    return wrapper


def instrument():
    """Wrap the comm layer's functions wherever pmpm's modules hold them, the World's
    methods, and Simulation.advance."""
    import pmpm.app  # noqa: F401  (imports the solver's modules)
    import pmpm.comm  # noqa: F401
    world_module = sys.modules["pmpm.comm.world"]
    from pmpm.solver.simulation import Simulation
    comm_functions = {}
    for name, module in list(sys.modules.items()):
        if name.startswith("pmpm.comm") and module is not None:
            for attr, value in vars(module).items():
                if callable(value) and getattr(value, "__module__", "").startswith("pmpm.comm") \
                        and not isinstance(value, type):
                    comm_functions[id(value)] = timed_comm(value)
    for name, module in list(sys.modules.items()):
        if name.startswith("pmpm") and module is not None:
            for attr, value in list(vars(module).items()):
                if id(value) in comm_functions:
                    setattr(module, attr, comm_functions[id(value)])
    for attr, value in list(vars(world_module.World).items()):
        if callable(value) and not attr.startswith("__"):
            setattr(world_module.World, attr, timed_comm(value))
    advance = Simulation.advance

    def timed_advance(self, dt):
        STATE["in_step"] = True
        cpu, wall = time.process_time(), time.perf_counter()
        comm = TIMES["comm_cpu_s"]
        try:
            return advance(self, dt)
        finally:
            STATE["in_step"] = False
            TIMES["busy_cpu_s"] += time.process_time() - cpu - (TIMES["comm_cpu_s"] - comm)
            TIMES["step_wall_s"] += time.perf_counter() - wall
            TIMES["steps"] += 1
    Simulation.advance = timed_advance


def run_instrumented(instrument_tree, times):
    """``python SCRIPT TREE OUT.json CASE [pmpm args]``: put TREE first on the path, call
    ``instrument_tree()``, run pmpm, write every rank's ``times`` to OUT.json on rank 0
    and exit with pmpm's status (scripts/phase_times.py uses it too)."""
    tree, out, argv = sys.argv[1], sys.argv[2], sys.argv[3:]
    sys.path.insert(0, tree)
    instrument_tree()
    from mpi4py import MPI
    from pmpm.__main__ import main as pmpm_main
    status = pmpm_main(argv)
    every = MPI.COMM_WORLD.allgather(dict(times))
    if MPI.COMM_WORLD.Get_rank() == 0:
        with open(out, "w", encoding="utf-8") as f:
            json.dump({"status": status, "ranks": every}, f, indent=1)
    sys.exit(status)


def main():
    run_instrumented(instrument, TIMES)


if __name__ == "__main__":
    main()
