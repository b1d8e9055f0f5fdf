"""Where each rank's step time goes, method by method (issue 25: the work that grows with
the rank count): the exclusive CPU and wall time of every Python method of pmpm's
classes and every pmpm.comm function called inside ``Simulation.advance``, per rank.

A method's exclusive time is its own, less the wrapped calls it made (a kind's method
that calls a Numba kernel keeps the kernel's time: kernels are not wrapped, so that no
kernel can see a wrapper when it compiles). No pmpm code is changed.

Run under mpirun with the checkout to measure first:

    mpirun -n 4 TREE/.venv/bin/python scripts/phase_times.py TREE OUT.json CASE.yaml [pmpm args]

OUT.json: ``{"status", "ranks": [{name: [calls, cpu_s, wall_s]}, ...]}``. Compare runs on
1 and P ranks with ``python scripts/phase_times.py --compare ONE.json P.json``: for each
name, the CPU summed over the ranks against 1 rank's, and the busiest rank's.

``--faults`` first (``scripts/phase_times.py --faults TREE OUT.json CASE ...``) counts
each method's minor page faults (``getrusage``) in the place of its CPU seconds: the
step's fresh arrays that the system zero-fills page by page (docs/performance-notes.md,
"Memory: returning freed memory to the system").
"""
import functools
import inspect
import json
import resource
import sys
import time

WRAPPED_MODULES = ("pmpm.solver", "pmpm.comm", "pmpm.grid", "pmpm.particles", "pmpm.io",
                   "pmpm.fem")
STATE = {"in_step": False, "stack": [], "clock": time.process_time}
TIMES = {}


def timed(name, function):
    """``function`` with its exclusive CPU and wall time added to TIMES[name] while a step
    runs."""
    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        if not STATE["in_step"]:
            return function(*args, **kwargs)
        frame = [STATE["clock"](), time.perf_counter(), 0.0, 0.0]
        STATE["stack"].append(frame)
        try:
            return function(*args, **kwargs)
        finally:
            STATE["stack"].pop()
            cpu = STATE["clock"]() - frame[0]
            wall = time.perf_counter() - frame[1]
            entry = TIMES.setdefault(name, [0, 0.0, 0.0])
            entry[0] += 1
            entry[1] += cpu - frame[2]
            entry[2] += wall - frame[3]
            if STATE["stack"]:
                STATE["stack"][-1][2] += cpu
                STATE["stack"][-1][3] += wall
    return wrapper


def minor_faults():
    """Minor page faults of this process so far (the clock of ``--faults``)."""
    return float(resource.getrusage(resource.RUSAGE_SELF).ru_minflt)


def pmpm_modules(prefixes):
    return [(name, module) for name, module in list(sys.modules.items())
            if module is not None and name.startswith(prefixes)]


def wrap_classes():
    """Every plain method of every class defined in a pmpm module."""
    for name, module in pmpm_modules("pmpm."):
        if name.startswith(("pmpm.kernels", "pmpm.case")):
            continue
        for cls in list(vars(module).values()):
            if not isinstance(cls, type) or cls.__module__ != name:
                continue
            for attr, value in list(vars(cls).items()):
                if inspect.isfunction(value) and (not attr.startswith("__") or attr == "__call__"):
                    setattr(cls, attr, timed(f"{cls.__name__}.{attr}", value))


def wrap_functions():
    """Module-level Python functions of the solver, comm, grid ... packages, wherever a
    pmpm module holds them."""
    originals = {}
    for name, module in pmpm_modules(WRAPPED_MODULES):
        for attr, value in vars(module).items():
            if inspect.isfunction(value) and value.__module__ == name:
                label = f"{name.rsplit('.', 1)[-1]}.{attr}"
                originals[id(value)] = timed(label, value)
    for name, module in pmpm_modules("pmpm"):
        if name.startswith("pmpm.kernels"):
            continue
        for attr, value in list(vars(module).items()):
            if id(value) in originals:
                setattr(module, attr, originals[id(value)])


def instrument():
    import pmpm.app  # noqa: F401  (imports the solver's modules)
    import pmpm.comm  # noqa: F401
    from pmpm.solver.simulation import Simulation
    wrap_functions()
    wrap_classes()
    advance = Simulation.advance

    def traced_advance(self, dt):
        STATE["in_step"] = True
        try:
            return advance(self, dt)
        finally:
            STATE["in_step"] = False
    Simulation.advance = traced_advance


def compare(one_path, many_path, top=25):
    """Print, per name, 1 rank's CPU, P ranks' summed CPU, their ratio and the busiest
    rank's share: the lines whose sum grows are the work that grows with the ranks."""
    one = json.load(open(one_path))["ranks"][0]
    many = json.load(open(many_path))["ranks"]
    names = set(one) | {n for r in many for n in r}
    rows = []
    for n in names:
        cpu1 = one.get(n, [0, 0.0, 0.0])[1]
        per_rank = [r.get(n, [0, 0.0, 0.0])[1] for r in many]
        rows.append((sum(per_rank) - cpu1, n, cpu1, sum(per_rank), max(per_rank),
                     sum(per_rank) / len(per_rank)))
    total1 = sum(r[2] for r in rows)
    totalp = sum(r[3] for r in rows)
    print(f"{'name':48s} {'1 rank s':>9s} {f'{len(many)} ranks sum':>12s} {'growth s':>9s} "
          f"{'max/mean':>8s}")
    for growth, n, cpu1, sump, maxp, meanp in sorted(rows, reverse=True)[:top]:
        ratio = maxp / meanp if meanp > 0 else 0.0
        print(f"{n:48s} {cpu1:9.3f} {sump:12.3f} {growth:+9.3f} {ratio:8.2f}")
    print(f"{'all':48s} {total1:9.3f} {totalp:12.3f} {totalp - total1:+9.3f}")


def main():
    if sys.argv[1] == "--compare":
        compare(sys.argv[2], sys.argv[3])
        return
    if sys.argv[1] == "--faults":
        STATE["clock"] = minor_faults
        del sys.argv[1]
    from busy_time import run_instrumented
    run_instrumented(instrument, TIMES)


if __name__ == "__main__":
    main()
