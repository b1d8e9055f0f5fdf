"""Which of pmpm's Numba kernels compile (or load) during a case's first steps after the
warm-up: the kernels' dispatchers and the signatures they gain (tests/test_warmup.py).

Run as a script in a fresh interpreter (``python tests/warmhelp.py CASE [--bare]``) it
prints, as JSON, the kernels that gained a signature in the steps and those that have one
at the end; ``--bare`` warms up the MPM step only (the FEM and coupling kinds of
``kernels_of`` off), the control that shows the check sees what the warm-up leaves out."""
import importlib
import json
import os
import pkgutil
import sys

STEPS = 2


def pmpm_dispatchers():
    """Qualified name -> CPUDispatcher of every kernel defined in pmpm.kernels.*,
    pmpm.fem.* and pmpm.materials.* (the modules that hold Numba kernels)."""
    from numba.core.registry import CPUDispatcher

    import pmpm
    found = {}
    for info in pkgutil.walk_packages(pmpm.__path__, "pmpm."):
        if info.name.split(".")[1] not in ("kernels", "fem", "materials"):
            continue
        module = importlib.import_module(info.name)
        for name, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.__module__ == info.name:
                found[f"{info.name}.{name}"] = value
    return found


def signatures(dispatchers):
    return {name: set(d.signatures) for name, d in dispatchers.items()}


def gained_in_steps(case, world=None, bare=False, steps=STEPS):
    """(kernels that gained a signature in ``steps`` steps of ``case`` after
    ``warm_up(**kernels_of(config))``, kernels with a signature at the end)."""
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from runhelp import set_up

    from pmpm.case.loader import load_config
    from pmpm.kernels.shape import SHAPE_CODES
    from pmpm.kernels.warmup import kernels_of, warm_up
    config = load_config(case, [])
    kinds = kernels_of(config)
    if bare:
        kinds = {k: v for k, v in kinds.items() if k in ("apic", "contact", "ties", "mirrors")}
    warm_up(SHAPE_CODES[config.grid.shape_functions], **kinds)
    sim = set_up(case, (), world)
    dispatchers = pmpm_dispatchers()
    before = signatures(dispatchers)
    for _ in range(steps):
        fastest = sim.fastest_speed()
        sim.advance(0.4 * sim.grid.h / fastest)
    after = signatures(dispatchers)
    return (sorted(k for k in after if after[k] - before[k]),
            sorted(k for k in after if after[k]))


if __name__ == "__main__":
    gained, compiled = gained_in_steps(sys.argv[1], bare="--bare" in sys.argv)
    print(json.dumps({"gained": gained, "compiled": compiled}))
