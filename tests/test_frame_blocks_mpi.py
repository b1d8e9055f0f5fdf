"""Frames by body on 2 or more ranks (issue 26): whatever order each rank holds its
particles in, particles.h5 stores body 0's rows (rank 0's, then rank 1's ...), then body
1's, and so on, with ``body_counts``; a body that no rank holds gets no XDMF grid; the
file is the one a single rank writes for the same particles, up to the order within a
body.

Run with: mpirun -n 2 python -m pytest --with-mpi -m mpi tests/test_frame_blocks_mpi.py
"""
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from pmpm.io import ParticleWriter
from xdmfread import grid_arrays

BODIES = ["plate", "empty", "ball", "rod"]      # no rank holds "empty"


def rank_rows(rank, n):
    """Rows of one rank in a shuffled body order; rank 0 holds no ``rod``. Values encode
    the id, so that rows can be matched to ids in the file."""
    rng = np.random.default_rng(rank)
    choices = [0, 2] if rank == 0 else [0, 2, 3]
    ids = np.arange(n, dtype=np.int64) + 1000 * rank
    return {"x": ids[:, None] * [1.0, 2.0, 3.0], "v": np.zeros((n, 3)),
            "stress": ids[:, None] * np.arange(1.0, 7.0), "eps_p": ids * 0.5,
            "density": np.ones(n), "mass": ids + 1.0,
            "body": rng.choice(choices, n).astype(np.int32), "id": ids,
            "damage": np.zeros(n, np.float32)}


def write(path, comm, parts):
    writer = ParticleWriter(path, comm, "case", {"body_names": BODIES})
    writer.write_frame(0.0, 0, parts)
    writer.close()


@pytest.mark.mpi(min_size=2)
def test_rows_by_body_across_ranks_match_one_rank(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    parts = [rank_rows(r, 7 + 3 * r) for r in range(comm.size)]
    write(mpi_tmp_path / "many", comm, parts[comm.rank])
    if comm.rank == 0:
        whole = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        write(mpi_tmp_path / "one", MPI.COMM_SELF, whole)
    comm.Barrier()
    if comm.rank == 0:
        # expected order: by body, then rank, then the rank's own order
        order = np.argsort(whole["body"], kind="stable")
        counts = np.bincount(whole["body"], minlength=len(BODIES))
        with h5py.File(mpi_tmp_path / "many/particles.h5", "r") as many, \
                h5py.File(mpi_tmp_path / "one/particles.h5", "r") as one:
            group = many["frames/000000"]
            np.testing.assert_array_equal(group.attrs["body_counts"], counts)
            for name, array in whole.items():
                np.testing.assert_array_equal(group[name][()], array[order], err_msg=name)
                by_id = np.argsort(one["frames/000000/id"][()])
                np.testing.assert_array_equal(one["frames/000000"][name][()][by_id],
                                              array, err_msg=name)
            steps = ET.parse(mpi_tmp_path / "many/particles.xdmf").getroot().findall(
                "./Domain/Grid/Grid")
            grids = steps[0].findall("Grid")
            assert [g.get("Name") for g in grids] == ["plate", "ball", "rod"]
            for grid, b in zip(grids, (0, 2, 3)):
                arrays = grid_arrays(grid, many)
                mine = whole["body"][order] == b
                np.testing.assert_array_equal(arrays["id"], whole["id"][order][mine])
                np.testing.assert_array_equal(arrays["geometry"], whole["x"][order][mine])
                np.testing.assert_array_equal(arrays["damage"], whole["damage"][order][mine])
    comm.Barrier()


@pytest.mark.mpi(min_size=2)
def test_a_negative_body_index_fails_on_every_rank(mpi_tmp_path):
    comm = MPI.COMM_WORLD
    parts = rank_rows(comm.rank, 4)
    if comm.rank == 1:
        parts["body"][2] = -1
    writer = ParticleWriter(mpi_tmp_path, comm, "case", {"body_names": BODIES})
    with pytest.raises(ValueError, match=r"negative body indices on ranks \[1\]"):
        writer.write_frame(0.0, 0, parts)
    writer.close()
