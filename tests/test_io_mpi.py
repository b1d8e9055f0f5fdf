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


def body_major(columns):
    """Rows as a frame stores them: by body, and within a body rank after rank (the order
    of ``columns``, the ranks' parts concatenated)."""
    order = np.argsort(columns["body"], kind="stable")
    return {name: array[order] for name, array in columns.items()}


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
        expected.append(body_major(concatenated(parts)))
    writer.close({"ranks": comm.size})
    comm.Barrier()
    if comm.rank == 0:
        with h5py.File(mpi_tmp_path / "particles.h5", "r") as f:
            assert f.attrs["frames"] == 2 and f.attrs["ranks"] == comm.size
            for index, columns in enumerate(expected):
                group = f[f"frames/{index:06d}"]
                assert group.attrs["n"] == len(columns["id"])
                np.testing.assert_array_equal(group.attrs["body_counts"],
                                              np.bincount(columns["body"], minlength=2))
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


def chain_frame(comm, gone):
    """A chain of 10 hexahedra (element e uses nodes 4e .. 4e + 7) without the elements
    ``gone`` and the nodes only they used, dealt out so that elements go to ranks in
    reverse order to ranks 1, 2, ... and nodes round-robin: (nodes, elements) of this rank in
    FemBodies.frame's form."""
    present = np.array([e for e in range(10) if e not in gone], np.int64)
    corners = 4 * present[:, None] + np.arange(8)
    node_ids = np.unique(corners)
    mine = 1 + present % (comm.size - 1) == comm.rank    # rank 0 holds no element
    nodes = {"node_id": node_ids[node_ids % comm.size == comm.rank]}
    nodes["node_x"] = np.repeat(nodes["node_id"][:, None], 3, axis=1) * [1.0, 2.0, 3.0]
    elements = {"element_id": present[mine][::-1].copy(), "hexes": corners[mine][::-1].copy(),
                "body": (present[mine][::-1] % 2).astype(np.int32),
                "eps_p": present[mine][::-1] * 0.5}
    return nodes, elements


@pytest.mark.mpi(min_size=2)
@pytest.mark.parametrize("gone", [(), (0, 5, 9)])
def test_element_rows_follow_ids_whatever_rank_holds_them(mpi_tmp_path, gone):
    """Element frames lay rows out by id (pmpm.io.elements_h5.laid_out): nodes and
    elements held by any rank, in any order, rank 0 holding no element; the connectivity
    points at the rows of its nodes in the file, also when ids are missing (elements gone
    into particles)."""
    from pmpm.io.elements_h5 import laid_out, write_laid_out
    comm = MPI.COMM_WORLD
    nodes, elements = laid_out(comm, *chain_frame(comm, gone))
    path = str(mpi_tmp_path / f"chain{len(gone)}.h5")
    with h5py.File(path, "w", driver="mpio", comm=comm) as f:
        n_nodes = write_laid_out(f.create_group("nodes"), comm, nodes)
        n_elements = write_laid_out(f.create_group("elements"), comm, elements)
    comm.Barrier()
    if comm.rank == 0:
        with h5py.File(path, "r") as f:
            node_id, x = f["nodes/node_id"][()], f["nodes/node_x"][()]
            element_id, hexes = f["elements/element_id"][()], f["elements/hexes"][()]
            eps_p, body = f["elements/eps_p"][()], f["elements/body"][()]
        present = np.array([e for e in range(10) if e not in gone])
        assert n_elements == len(present) and n_nodes == 44 - 8 * bool(gone)
        assert (element_id == present).all()
        assert (node_id == np.unique(4 * present[:, None] + np.arange(8))).all()
        assert (x == node_id[:, None] * [1.0, 2.0, 3.0]).all()
        assert (node_id[hexes] == 4 * present[:, None] + np.arange(8)).all()
        assert (eps_p == present * 0.5).all() and (body == present % 2).all()
