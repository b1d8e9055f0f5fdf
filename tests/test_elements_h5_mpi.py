"""pytest-mpi (2 or more ranks): the element frames written collectively on N ranks hold
what the 1-rank run writes, row for row in node and element id order, to round-off: the
FEM Taylor bar cut by the slab plane, with elements moving between ranks at balance
checks, once with its foot converting into particles (frames with their own
connectivity) and once without.
Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_elements_h5_mpi.py"""
import h5py
import numpy as np
import pytest
from mpi4py import MPI

from pmpm.io.elements_h5 import ElementWriter
from test_conversion import run, simulation
from test_conversion_mpi import comm_world

EVERY = 25          # steps between a balance check and an element frame


def write_run(sim, path, comm, end):
    """Run ``sim`` to ``end`` writing an element frame at the start, after every balance
    check and at the end."""
    writer = ElementWriter(str(path), sim.elements, sim.bodies.names, comm)
    writer.write_frame(sim.time, sim.step_count)

    def every(s):
        if s.step_count % EVERY == 0:
            s.rebalance(0.01)
            s.sort_by_cell()
            writer.write_frame(s.time, s.step_count)
    run(sim, end, every)
    writer.write_frame(sim.time, sim.step_count)
    writer.close()
    return sim


def read_frames(path):
    """Per frame {name: rows} with ``hexes`` as node ids and ``body``, from /mesh where
    the frame has none."""
    with h5py.File(path, "r") as f:
        mesh = {k: f["mesh"][k][()] for k in ("hexes", "body")}
        frames = []
        for name in sorted(f["frames"]):
            group = f["frames"][name]
            frame = {k: group[k][()] for k in group}
            frame["own"] = "hexes" in frame
            frame.update({k: frame.get(k, mesh[k]) for k in mesh})
            frame["hexes"] = frame["node_id"][frame["hexes"]]
            frame["time"], frame["step"] = group.attrs["time"], group.attrs["step"]
            frames.append(frame)
    return frames


def assert_same_frames(n_frames, one_frames):
    assert len(n_frames) == len(one_frames) > 2
    for n, one in zip(n_frames, one_frames):
        assert n["step"] == one["step"] and n["own"] == one["own"]
        assert n.keys() == one.keys()
        for ids in ("node_id", "element_id"):
            assert (np.diff(n[ids]) > 0).all()          # rows in ascending id order
            assert (n[ids] == one[ids]).all()
        for key in ("hexes", "body"):
            assert (n[key] == one[key]).all(), key
        for key in n.keys() - {"node_id", "element_id", "hexes", "body", "step", "own"}:
            scale = max(np.abs(one[key]).max(), 1.0)
            assert np.abs(n[key] - one[key]).max() <= 1e-10 * scale, key


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("eps_c, end", [(0.9, 0.024), (100.0, 0.006)],
                         ids=["converting", "not-converting"])
def test_element_frames_on_n_ranks_are_the_one_rank_frames(mpi_tmp_path, eps_c, end):
    world = comm_world()
    overrides = ["decomposition.axis=y", f"params.eps_c={eps_c}", f"time.end={end}"]
    many = write_run(simulation(overrides, world), mpi_tmp_path / "n.h5", world.raw, end)
    if world.is_root:                                  # the 1-rank run, on rank 0
        write_run(simulation(overrides), mpi_tmp_path / "one.h5", MPI.COMM_SELF, end)
    converted = many.conversion.converted
    assert (converted > 0) == (eps_c < 1)
    assert world.allgather(many.elements.n_elements).count(0) == 0   # both ranks hold some
    world.barrier()
    if world.is_root:
        n_frames = read_frames(mpi_tmp_path / "n.h5")
        assert_same_frames(n_frames, read_frames(mpi_tmp_path / "one.h5"))
        assert n_frames[-1]["own"] == (converted > 0) and not n_frames[0]["own"]
        assert len(n_frames[-1]["element_id"]) == len(n_frames[0]["element_id"]) - converted
