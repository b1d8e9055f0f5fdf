"""Each rank's messages and bytes per step, by the solver method that sent them (issue 24:
which phases of the step exchange what). ``World.traffic.note`` is wrapped from outside
(no pmpm code is changed): every note made inside ``Simulation.advance`` is charged to
the innermost caller outside pmpm.comm, as ``module.function``, and to its kind
(neighbour, collective, alltoall). A sparse exchange notes its messages as neighbour and
its barrier as one collective; a reduction or gather notes one collective.

Run under mpirun with the checkout to measure first:

    mpirun -n 2 TREE/.venv/bin/python scripts/traffic_phases.py TREE OUT.json CASE.yaml [pmpm args]

OUT.json: ``{"status", "ranks": [{"steps": n, "phases": {caller: {kind: [messages,
bytes]}}}, ...]}``; ``--show OUT.json`` prints them per step.
"""
import json
import sys

TIMES = {"steps": 0, "phases": {}}
STATE = {"in_step": False}


def caller():
    """``module.function`` of the innermost frame outside pmpm.comm and this script."""
    frame = sys._getframe(2)
    while frame is not None:
        module = frame.f_globals.get("__name__", "")
        if module.startswith("pmpm") and not module.startswith("pmpm.comm"):
            return f"{module.removeprefix('pmpm.')}.{frame.f_code.co_name}"
        frame = frame.f_back
    return "?"


def instrument():
    import pmpm.app  # noqa: F401  (imports the solver's modules)
    from pmpm.comm.world import Traffic
    from pmpm.solver.simulation import Simulation
    note = Traffic.note

    def counted_note(self, kind, nbytes, messages=1):
        if STATE["in_step"]:
            entry = TIMES["phases"].setdefault(caller(), {}).setdefault(kind, [0, 0])
            entry[0] += int(messages)
            entry[1] += int(nbytes)
        return note(self, kind, nbytes, messages)
    Traffic.note = counted_note
    advance = Simulation.advance

    def counted_advance(self, dt):
        STATE["in_step"] = True
        try:
            return advance(self, dt)
        finally:
            STATE["in_step"] = False
            TIMES["steps"] += 1
    Simulation.advance = counted_advance


def show(path):
    """Print each rank's messages and bytes per step, by caller and kind."""
    with open(path, encoding="utf-8") as f:
        ranks = json.load(f)["ranks"]
    for r, times in enumerate(ranks):
        steps = max(times["steps"], 1)
        print(f"rank {r}: {times['steps']} steps; per step: messages, bytes")
        total = {}
        for name, kinds in sorted(times["phases"].items()):
            for kind, (messages, nbytes) in sorted(kinds.items()):
                print(f"  {name:55s} {kind:10s} {messages / steps:7.2f} {nbytes / steps:11.0f}")
                t = total.setdefault(kind, [0, 0])
                t[0] += messages
                t[1] += nbytes
        for kind, (messages, nbytes) in sorted(total.items()):
            print(f"  {'all':55s} {kind:10s} {messages / steps:7.2f} {nbytes / steps:11.0f}")


def main():
    if sys.argv[1] == "--show":
        show(sys.argv[2])
        return
    from busy_time import run_instrumented
    run_instrumented(instrument, TIMES)


if __name__ == "__main__":
    main()
