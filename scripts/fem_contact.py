"""The figures of docs/validation/fem_contact.md: node-to-surface contact between FEM
bodies, in process, one rank.

    PYTHONPATH=. python scripts/fem_contact.py bars 1.0     # element size (mm): 1.0, 0.5, 0.25
    PYTHONPATH=. python scripts/fem_contact.py sliding [KEY=VALUE ...]   # e.g. params.mu=0.0
    PYTHONPATH=. python scripts/fem_contact.py cost 0.25 params.width=2.0

Prints one JSON line. bars: final velocities / v, the last step with contact against
2 L / c, the target's momentum rate over the middle half of the pulse / (rho c A v / 2),
energy at the end and its extremes / start, momentum drift. sliding: the block's
deceleration after 4 ms (mu g = 30 m/s^2), final vx. cost: ms a step with the contact and
with the coupling taken out of the step."""
import json
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "tests"))
from test_fem_contact import (BARS, SLIDING, body_momentum, run, simulation,  # noqa: E402
                              total_momentum)

RHO, E, V, LENGTH, AREA = 7.85e-3, 2.0e5, 10.0, 10.0, 1.0
C = np.sqrt(E / RHO)


def bars(element, extra=()):
    sim = simulation(BARS, [f"params.element={element}"] + list(extra))
    e0, p0 = sim.energies()["total"], total_momentum(sim)
    mass = RHO * LENGTH * AREA
    rows = []
    run(sim, lambda s: rows.append((s.time, body_momentum(s, 0)[0], body_momentum(s, 1)[0],
                                    s.energies()["total"], s.node_contact.last_pairs)))
    t, striker, target, energy, pairs = np.array(rows).T
    pulse = 2 * LENGTH / C
    mid = (t > 0.25 * pulse) & (t < 0.75 * pulse)
    return {"element": element, "steps": len(t), "striker_v": striker[-1] / mass / V,
            "target_v": target[-1] / mass / V, "contact_end_us": 1e3 * t[pairs > 0][-1],
            "pulse_us": 1e3 * pulse,
            "force": np.polyfit(t[mid], target[mid], 1)[0] / (RHO * C * AREA * V / 2),
            "energy_end": energy[-1] / e0, "energy_min": energy.min() / e0,
            "energy_max": energy.max() / e0,
            "momentum": float(np.abs(total_momentum(sim) - p0).max() / np.abs(p0).max())}


def sliding(extra=()):
    sim = simulation(SLIDING, list(extra))
    fem = sim.elements
    block = fem.node_body == 1
    mass = fem.mass[block].sum()
    rows = []
    run(sim, lambda s: rows.append((s.time, fem.mass[block] @ fem.v[block, 0] / mass)))
    t, vx = np.array(rows).T
    late = t > 0.004
    return {"deceleration": -np.polyfit(t[late], vx[late], 1)[0], "vx_end": vx[-1]}


def cost(element, extra=(), steps=60):
    out = {}
    for mode in ("with", "without"):
        sim = simulation(BARS, [f"params.element={element}"] + list(extra))
        if mode == "without":
            sim.stepper.couplings.remove(sim.node_contact)
        for _ in range(5):
            sim.advance(0.5 * sim.grid.h / sim.fastest_speed())
        start = time.perf_counter()
        for _ in range(steps):
            sim.advance(0.5 * sim.grid.h / sim.fastest_speed())
        out[f"ms_per_step_{mode}"] = 1e3 * (time.perf_counter() - start) / steps
    out.update(elements=sim.elements.n_elements, slaves=len(sim.node_contact.slaves),
               faces=len(sim.node_contact.face_key))
    return out


if __name__ == "__main__":
    what, args = sys.argv[1], sys.argv[2:]
    if what == "sliding":
        result = sliding(args)
    else:
        result = (bars if what == "bars" else cost)(float(args[0]), args[1:])
    print(json.dumps({k: float(v) if isinstance(v, np.floating) else v
                      for k, v in result.items()}))
