"""pytest-mpi (2 or more ranks): a body read from a point file (CSV, volumes per point),
with a surface-filled and a union body beside it, gives on N ranks the 1-rank answer to
round-off: every rank reads the same particles in the same order, so the global ids
and the slabs' shares agree.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_geometry_input_mpi.py"""
import numpy as np
import pytest
import yaml

from test_geometry_input import STEEL, cube_surface, triangles, write_csv, write_stl

DT = 5e-5
STEPS = 40


def write_case(folder):
    """A jittered cloud of particles (CSV) striking an STL plate at about 400 m/s (a
    velocity that varies over the cloud), the plate standing on a union of two boxes,
    all cut by the slab plane along x. Written by every rank into its own folder,
    identically."""
    rng = np.random.default_rng(7)
    axes = [np.arange(2.25, 6, 0.5), np.arange(2.25, 6, 0.5), np.arange(5.75, 8, 0.5)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    points = grid + rng.uniform(-0.05, 0.05, grid.shape)
    write_csv(folder / "cloud.csv", points, 0.125 * rng.uniform(0.9, 1.1, len(points)))
    corners, quads = cube_surface(2)
    write_stl(folder / "plate.stl", (corners + 1) / 2 * [6, 6, 2], triangles(quads))
    tree = {
        "grid": {"min": [0, 0, 0], "max": [8, 8, 10], "cell": 1.0},
        "materials": {"steel": STEEL},
        "bodies": [
            {"name": "cloud", "material": "steel",
             "geometry": {"type": "points", "file": "cloud.csv", "volume": "vol"},
             "velocity": ["2 * (y - 4)", "-3 * (x - 4)", "-400 - 5 * (z - 6)"]},
            {"name": "plate", "material": "steel",
             "geometry": {"type": "surface", "file": "plate.stl", "translate": [1, 1, 3]}},
            {"name": "feet", "material": "steel",
             "geometry": {"type": "union", "of": [
                 {"type": "box", "min": [1, 1, 1], "max": [3, 7, 3]},
                 {"type": "box", "min": [5, 1, 1], "max": [7, 7, 3]}]}}],
        "contact": {"method": 1},
        "decomposition": {"axis": "x"},
        "time": {"end": 1.0},
    }
    path = folder / "case.yaml"
    path.write_text(yaml.safe_dump(tree, sort_keys=False))
    return str(path)


def comm_world():
    from mpi4py import MPI
    from pmpm.comm import World
    return World(MPI.COMM_WORLD)


def gathered(world, sim):
    """(ids, x, v, stress) of every particle, ordered by id."""
    p = sim.particles
    parts = world.allgather((p.id, p.x, p.v, p.stress)) if world else \
        [(p.id, p.x, p.v, p.stress)]
    ids = np.concatenate([q[0] for q in parts])
    order = np.argsort(ids)
    return [ids[order]] + [np.concatenate([q[k] for q in parts])[order] for k in (1, 2, 3)]


@pytest.mark.mpi(min_size=2)
def test_a_point_file_body_on_n_ranks_gives_the_one_rank_answer(tmp_path):
    from runhelp import set_up
    world = comm_world()
    case = write_case(tmp_path)
    sims = {"n": set_up(case, world=world), "one": set_up(case)}
    for sim in sims.values():
        for _ in range(STEPS):
            sim.advance(DT)
    n_state, one_state = gathered(world, sims["n"]), gathered(None, sims["one"])
    assert world.allgather(int(sims["n"].particles.n)).count(0) == 0   # all ranks hold some
    assert len(n_state[0]) == len(one_state[0]) and (n_state[0] == one_state[0]).all()
    for a, b in zip(n_state[1:], one_state[1:]):
        assert np.abs(a - b).max() <= 1e-10 * max(np.abs(b).max(), 1.0)
    # the cloud struck the plate and the wave reached the feet (all three are loaded)
    body = sims["one"].particles.body[np.argsort(sims["one"].particles.id)]
    for b in range(3):
        assert np.abs(one_state[3][body == b]).max() > 100.0
