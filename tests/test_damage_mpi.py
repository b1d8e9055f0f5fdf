"""pytest-mpi (2 or more ranks): an impact with Johnson-Cook damage on N ranks gives the
1-rank answer to round-off (tests/cases/damage_impact.yaml: a particle rod into an FEM
plate whose elements convert into particles): the damage and plastic work of every
particle and element, the failed counts and the bodies' plastic work, with particles
migrating and elements changing rank on the way.
Run with: mpirun -n 2 python -m pytest --with-mpi -m mpi tests/test_damage_mpi.py"""
import os

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
CASE = os.path.join(HERE, "cases", "damage_impact.yaml")


def comm_world():
    from mpi4py import MPI
    from pmpm.comm import World
    return World(MPI.COMM_WORLD)


def by_id(world, ids, *columns):
    """``columns`` of every rank's rows, sorted by ``ids``."""
    parts = world.allgather((ids,) + columns) if world else [(ids,) + columns]
    ids = np.concatenate([p[0] for p in parts])
    order = np.argsort(ids)
    return (ids[order],) + tuple(np.concatenate([p[k] for p in parts])[order]
                                 for k in range(1, len(columns) + 1))


def run(sim, end):
    steps = 0
    while sim.time < end - 1e-12:
        sim.advance(min(0.5 * sim.grid.h / sim.fastest_speed(), end - sim.time))
        steps += 1
        if steps % 20 == 0:
            sim.rebalance(0.01)
            sim.sort_by_cell()


@pytest.mark.mpi(min_size=2)
def test_n_ranks_give_the_one_rank_damage():
    from runhelp import set_up
    world = comm_world()
    overrides = ["decomposition.axis=z", "time.end=0.005"]
    sims = {"n": set_up(CASE, overrides, world), "one": set_up(CASE, overrides)}
    for sim in sims.values():
        run(sim, 0.005)
    rows = {}
    for key, sim in sims.items():
        w = world if key == "n" else None
        p, fem = sim.particles, sim.elements
        rows[key] = (by_id(w, p.id, p.x, p.damage, p.w_p, p.eps_p),
                     by_id(w, fem.element_id, fem.state.damage, fem.state.w_p))
    for n_rows, one_rows in zip(rows["n"], rows["one"]):
        assert np.array_equal(n_rows[0], one_rows[0]) and len(one_rows[0]) > 0
        for a, b in zip(n_rows[1:], one_rows[1:]):
            assert np.abs(a - b).max() <= 1e-10 * max(np.abs(b).max(), 1.0)
    stats = {key: sim.body_stats() for key, sim in sims.items()}
    for body in ("rod", "plate"):
        n_body, one_body = stats["n"][body], stats["one"][body]
        assert n_body["n_failed"] == one_body["n_failed"] > 0
        assert n_body["energy"]["plastic"] == pytest.approx(one_body["energy"]["plastic"],
                                                            rel=1e-10)
    assert sims["n"].conversion.converted == sims["one"].conversion.converted > 0
    # both ranks held particles or elements at the end
    held = world.allgather(sims["n"].particles.n + sims["n"].elements.n_elements)
    assert min(held) > 0
