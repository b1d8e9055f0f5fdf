"""Output layer on 2 ranks: collective frames with an empty rank, checkpoints across ranks.

Run with: mpirun -n 2 python -m pytest --with-mpi tests/test_io_mpi.py
"""
import h5py
import numpy as np
import pytest
from mpi4py import MPI

from pmpm.io import ParticleWriter, load_checkpoint, save_checkpoint

BODIES = ["plate", "ball"]


def rows(n, first_id):
    """Columns whose values encode the global id, so the order in the file can be checked."""
    ids = np.arange(first_id, first_id + n, dtype=np.int64)
    return {
        "x": np.repeat(ids[:, None], 3, axis=1) + [0.0, 0.1, 0.2],
        "v": -np.repeat(ids[:, None], 3, axis=1).astype(float),
        "stress": np.repeat(ids[:, None], 6, axis=1) * 10.0,
        "eps_p": ids * 0.5, "density": ids + 1.0, "mass": ids + 2.0,
        "body": (ids % 2).astype(np.int32), "id": ids,
    }


def concatenated(parts):
    return {name: np.concatenate([part[name] for part in parts]) for name in parts[0]}


@pytest.mark.mpi(min_size=2)
def test_frame_with_an_empty_rank(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    # frame 0: rank 0 holds nothing; frame 1: only rank 0 holds particles
    counts = [[0] + [4] * (comm.size - 1), [3] + [0] * (comm.size - 1)]
    writer = ParticleWriter(mpi_tmp_path, comm, "case: 1\n", {"body_names": BODIES})
    expected = []
    for index, frame_counts in enumerate(counts):
        parts = [rows(n, 100 * r) for r, n in enumerate(frame_counts)]
        writer.write_frame(0.5 * index, 10 * index, parts[comm.rank])
        expected.append(concatenated(parts))
    writer.close({"ranks": comm.size})
    comm.Barrier()
    if comm.rank == 0:
        with h5py.File(mpi_tmp_path / "particles.h5", "r") as f:
            assert f.attrs["frames"] == 2 and f.attrs["ranks"] == comm.size
            for index, columns in enumerate(expected):
                group = f[f"frames/{index:06d}"]
                assert group.attrs["n"] == len(columns["id"])
                for name, array in columns.items():
                    np.testing.assert_array_equal(group[name][()], array)
    comm.Barrier()


@pytest.mark.mpi(min_size=2)
def test_checkpoint_rows_come_back_across_ranks(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    counts = [3, 5] + [0] * (comm.size - 2)
    parts = [rows(n, 100 * r) for r, n in enumerate(counts)]
    for r, part in enumerate(parts):
        part["F"] = np.full((counts[r], 9), r, dtype=np.float32)
    scalars = {"step": 7, "time": 0.25} if comm.rank == 0 else None  # rank 0's are stored
    path = save_checkpoint(mpi_tmp_path, comm, scalars, parts[comm.rank])
    loaded_scalars, loaded = load_checkpoint(path, comm)
    assert loaded_scalars == {"step": 7, "time": 0.25}
    total = sum(counts)
    assert len(loaded["id"]) == total * (comm.rank + 1) // comm.size - total * comm.rank // comm.size
    assert loaded["F"].dtype == np.float32 and loaded["F"].shape[1:] == (9,)
    gathered = comm.gather(loaded, root=0)
    if comm.rank == 0:
        expected = concatenated(parts)
        everything = concatenated(gathered)
        for name, array in expected.items():
            np.testing.assert_array_equal(everything[name], array)
        np.testing.assert_array_equal(everything["F"][:, 0], [0] * 3 + [1] * 5)


@pytest.mark.mpi(min_size=2)
def test_ranks_that_disagree_on_columns_fail_together(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    columns = rows(2, 10 * comm.rank)
    if comm.rank == 1:
        columns["temp"] = np.zeros(2)
    writer = ParticleWriter(mpi_tmp_path, comm, "", {"body_names": BODIES})
    with pytest.raises(ValueError, match="rank 1 has columns"):
        writer.write_frame(0.0, 0, columns)
    writer.close()
