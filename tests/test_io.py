"""Output layer on one rank (MPI.COMM_SELF): frames, XDMF, history, summary, checkpoints."""
import json
import os
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from pmpm.io import (HistoryWriter, ParticleWriter, latest_checkpoint, load_checkpoint,
                     save_checkpoint, write_summary)
from pmpm.io.checkpoint import list_checkpoints
from pmpm.io.summary import read_summary, validate_summary
from pmpm.io.xdmf import number_type, xdmf_text
from xdmfread import dims, grid_arrays

COMM = MPI.COMM_SELF
CASE = "name: test\nparams: {cell: 0.5}\n"
BODIES = ["plate", "ball"]


def particle_columns(n, seed=0, first_id=0):
    """Contract columns plus an extra 1D column (temp) and an extra 2D column (F)."""
    rng = np.random.default_rng(seed)
    return {
        "x": rng.random((n, 3)), "v": rng.random((n, 3)), "stress": rng.random((n, 6)),
        "eps_p": rng.random(n), "density": rng.random(n), "mass": rng.random(n),
        "body": rng.integers(0, 2, n).astype(np.int32),
        "id": np.arange(first_id, first_id + n, dtype=np.int64),
        "temp": rng.random(n), "F": rng.random((n, 9)),
    }


def write_frames(out, frames, **kwargs):
    writer = ParticleWriter(out, COMM, CASE, {"body_names": BODIES}, **kwargs)
    for time, step, columns in frames:
        writer.write_frame(time, step, columns)
    return writer


def test_frames_round_trip(tmp_path):
    cols = [particle_columns(7, seed=1), particle_columns(9, seed=2)]
    writer = write_frames(tmp_path, [(0.0, 0, cols[0]), (0.25, 40, cols[1])])
    writer.close({"wall_s": 2.5, "n_steps": np.int64(40)})
    with h5py.File(tmp_path / "particles.h5", "r") as f:
        assert f.attrs["frames"] == 2
        assert list(f.attrs["body_names"]) == BODIES
        assert f["case"].asstr()[()] == CASE
        assert json.loads(f.attrs["run_stats"]) == {"wall_s": 2.5, "n_steps": 40}
        for index, (time, step, columns) in enumerate([(0.0, 0, cols[0]), (0.25, 40, cols[1])]):
            group = f[f"frames/{index:06d}"]
            assert (group.attrs["time"], group.attrs["step"]) == (time, step)
            assert group["stress"].attrs["components"] == "xx,yy,zz,xy,yz,zx"
            assert list(group) == list(columns)
            # rows body-major: on one rank, the given rows stably sorted by body
            order = np.argsort(columns["body"], kind="stable")
            np.testing.assert_array_equal(group.attrs["body_counts"],
                                          np.bincount(columns["body"], minlength=2))
            for name, array in columns.items():
                assert group[name].dtype == array.dtype
                np.testing.assert_array_equal(group[name][()], array[order])


def test_empty_frame_is_written_and_listed_in_the_xdmf_without_data(tmp_path):
    empty = {name: array[:0] for name, array in particle_columns(3).items()}
    writer = write_frames(tmp_path, [(0.0, 0, particle_columns(3)), (1.0, 5, empty),
                                     (2.0, 9, particle_columns(2))])
    writer.close()
    with h5py.File(tmp_path / "particles.h5", "r") as f:
        assert f["frames/000001/x"].shape == (0, 3)
        assert f["frames/000001"].attrs["n"] == 0
    grids = ET.parse(tmp_path / "particles.xdmf").getroot().findall("./Domain/Grid/Grid")
    assert [g.find("Time").get("Value") for g in grids] == ["0.0", "1.0", "2.0"]
    assert [(g.get("GridType"), g.get("CollectionType")) for g in grids] == \
        [("Collection", "Spatial")] * 3
    assert len(list(grids[1])) == 1                    # the empty frame: only its time
    assert all(grids[k].findall("Grid") for k in (0, 2))


def test_xdmf_references_existing_datasets(tmp_path):
    """Every frame is a Spatial collection of one grid per body, named after it, whose
    items resolve to exactly that body's rows of the frame."""
    frames = [(0.0, 0, particle_columns(4)), (0.5, 10, particle_columns(6, seed=3))]
    write_frames(tmp_path, frames).close()
    root = ET.parse(tmp_path / "particles.xdmf").getroot()
    collection = root.find("./Domain/Grid")
    assert collection.get("CollectionType") == "Temporal"
    steps = collection.findall("Grid")
    assert [float(g.find("Time").get("Value")) for g in steps] == [0.0, 0.5]
    with h5py.File(tmp_path / "particles.h5", "r") as f:
        for step, (_, _, columns) in zip(steps, frames):
            present = np.unique(columns["body"])
            grids = step.findall("Grid")
            assert [g.get("Name") for g in grids] == [BODIES[b] for b in present]
            for grid, b in zip(grids, present):
                mine = columns["body"] == b
                assert grid.find("Topology").get("TopologyType") == "Polyvertex"
                for item in grid.iter("DataItem"):
                    if item.get("Format") == "HDF":
                        path = item.text.split(":")[1]
                        kind = (item.get("NumberType"), int(item.get("Precision")))
                        assert kind == number_type(f[path].dtype)
                arrays = grid_arrays(grid, f)
                np.testing.assert_array_equal(arrays["topology"], np.arange(mine.sum()))
                np.testing.assert_array_equal(arrays["geometry"], columns["x"][mine])
                np.testing.assert_array_equal(arrays["id"], columns["id"][mine])
                np.testing.assert_array_equal(arrays["F"], columns["F"][mine])
                kinds = {a.get("Name"): a.get("AttributeType") for a in grid.findall("Attribute")}
                assert kinds["v"] == "Vector" and kinds["F"] == "Tensor" and kinds["id"] == "Scalar"
                for k, name in enumerate(("sxx", "syy", "szz", "sxy", "syz", "szx")):
                    assert kinds[name] == "Scalar"
                    np.testing.assert_array_equal(arrays[name], columns["stress"][mine, k])


def test_xdmf_stress_scalars_select_their_column(tmp_path):
    columns = particle_columns(5)
    write_frames(tmp_path, [(0.0, 0, columns)]).close()
    counts = np.bincount(columns["body"], minlength=2)
    assert counts.min() > 0
    grids = ET.parse(tmp_path / "particles.xdmf").getroot().findall("./Domain/Grid/Grid/Grid")
    for grid, first, count in zip(grids, (0, counts[0]), counts):
        for k, name in enumerate(("sxx", "syy", "szz", "sxy", "syz", "szx")):
            slab = grid.find(f"./Attribute[@Name='{name}']/DataItem")
            assert slab.get("ItemType") == "HyperSlab" and dims(slab) == (count, 1)
            selector, source = slab.findall("DataItem")
            start, stride, size = np.array(selector.text.split(), dtype=int).reshape(3, 2)
            assert (tuple(start), tuple(stride), tuple(size)) == ((first, k), (1, 1), (count, 1))
            assert source.text.endswith("/frames/000000/stress") and dims(source) == (5, 6)


def test_restart_drops_later_frames(tmp_path):
    frames = [(0.1 * k, k, particle_columns(3, seed=k)) for k in range(3)]
    write_frames(tmp_path, frames).close()
    writer = ParticleWriter(tmp_path, COMM, CASE, {"body_names": BODIES}, restart_frame=2)
    assert writer.n_frames == 2
    assert writer.write_frame(0.15, 7, particle_columns(4)) == 2
    writer.close()
    with h5py.File(tmp_path / "particles.h5", "r") as f:
        assert f.attrs["frames"] == 3 and f["frames/000002"].attrs["step"] == 7
    root = ET.parse(tmp_path / "particles.xdmf").getroot()
    times = [float(t.get("Value")) for t in root.iter("Time")]
    assert times == [0.0, 0.1, 0.15]
    # the writer builds each frame's element once; the document is the one of all frames
    assert (tmp_path / "particles.xdmf").read_text() == \
        xdmf_text("particles.h5", writer.frames, BODIES)


def test_columns_of_different_lengths_are_refused(tmp_path):
    columns = particle_columns(3)
    columns["mass"] = columns["mass"][:2]
    writer = ParticleWriter(tmp_path, COMM, CASE, {"body_names": BODIES})
    with pytest.raises(ValueError, match="differ in length"):
        writer.write_frame(0.0, 0, columns)
    writer.close()


def test_frames_without_contract_columns_are_refused(tmp_path):
    columns = particle_columns(3)
    del columns["id"]
    columns["stress"] = columns["stress"][:, :3]
    writer = ParticleWriter(tmp_path, COMM, CASE, {"body_names": BODIES})
    with pytest.raises(ValueError, match=r"missing columns \['id'\]; stress has rows of shape"):
        writer.write_frame(0.0, 0, columns)
    writer.close()


CRASHING_RUN = """
    import os, numpy as np
    from mpi4py import MPI
    from pmpm.io import ParticleWriter
    def columns(n):
        z = np.zeros(n)
        return {"x": np.zeros((n, 3)), "v": np.zeros((n, 3)), "stress": np.zeros((n, 6)),
                "eps_p": z, "density": z, "mass": z, "body": np.zeros(n, np.int32),
                "id": np.arange(n)}
    writer = ParticleWriter(OUT, MPI.COMM_SELF, "case", {"body_names": ["a"]})
    writer.write_frame(0.0, 0, columns(3))
    writer.write_frame(1.0, 9, columns(4))
    os._exit(1)  # dies without closing anything
"""


def test_crashed_run_leaves_readable_frames_and_xdmf(tmp_path):
    code = textwrap.dedent(CRASHING_RUN).replace("OUT", repr(str(tmp_path)))
    # a clean MPI environment, so that the child starts as a singleton even under mpirun
    env = {k: v for k, v in os.environ.items() if not k.startswith(("OMPI_", "PMIX_", "PMI_"))}
    assert subprocess.run([sys.executable, "-c", code], env=env, timeout=60).returncode == 1
    with h5py.File(tmp_path / "particles.h5", "r") as f:
        assert f.attrs["frames"] == 2 and f["frames/000001/x"].shape == (4, 3)
    grids = ET.parse(tmp_path / "particles.xdmf").getroot().findall("./Domain/Grid/Grid")
    assert [g.find("Time").get("Value") for g in grids] == ["0.0", "1.0"]


def test_history_header_rows_and_restart(tmp_path):
    with HistoryWriter(tmp_path, BODIES) as history:
        for step in (0, 10, 20):
            bodies = {"plate": range(10), "ball": np.ones(10)}
            history.row(step, 0.1 * step, 0.01, (1.0, 2.0, 3.0, 0.5), bodies)
            with open(tmp_path / "history.csv") as handle:  # flushed while still open
                assert handle.read().splitlines()[-1].startswith(f"{step},")
    lines = (tmp_path / "history.csv").read_text().splitlines()
    assert lines[0] == ("step,time,dt,kinetic,internal,total,dissipated,"
                        "plate.x,plate.y,plate.z,plate.vx,plate.vy,plate.vz,plate.kinetic,"
                        "plate.internal,plate.plastic,plate.hourglass,"
                        "ball.x,ball.y,ball.z,ball.vx,ball.vy,ball.vz,ball.kinetic,ball.internal,"
                        "ball.plastic,ball.hourglass")
    row = [float(v) for v in lines[2].split(",")]
    assert row == [10, 1.0, 0.01, 1, 2, 3, 0.5, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9] + [1] * 10
    with HistoryWriter(tmp_path / "history.csv", BODIES, restart_step=10) as history:
        history.row(15, 1.5, 0.01, (1, 2, 3, 0), [[0] * 10, [0] * 10])
    steps = [line.split(",")[0] for line in (tmp_path / "history.csv").read_text().splitlines()]
    assert steps == ["step", "0", "10", "15"]


def test_history_rejects_wrong_body_rows(tmp_path):
    with HistoryWriter(tmp_path, BODIES) as history, pytest.raises(ValueError, match="body_rows"):
        history.row(0, 0.0, 0.1, (0, 0, 0, 0), [[0] * 6])


def summary_values():
    body = {"mass": 1.5, "n_particles": 10, "centroid": np.zeros(3), "velocity": [0, 0, -1.0],
            "bbox_min": [0, 0, 0], "bbox_max": [1, 1, 1]}
    return {"ranks": 2, "n_particles": {"initial": 20, "final": np.int64(22)}, "n_steps": 100,
            "t_end": 0.01, "wall_s": 3.0, "compile_s": 1.0, "particle_steps_per_s": 1e6,
            "energy": {"kinetic": 1.0, "internal": 0.5, "total": 1.5},
            "bodies": {"plate": body, "ball": dict(body)}, "extra": {"note": "kept"}}


def test_summary_written_with_contract_keys(tmp_path):
    path = write_summary(tmp_path, summary_values())
    assert path == os.path.join(tmp_path, "summary.json")
    data = read_summary(tmp_path)
    assert data["n_particles"] == {"initial": 20, "final": 22}
    assert data["bodies"]["ball"]["centroid"] == [0.0, 0.0, 0.0]
    assert data["extra"] == {"note": "kept"}
    assert [p for p in os.listdir(tmp_path) if "tmp" in p] == []


def test_summary_problems_name_their_keys(tmp_path):
    summary = summary_values()
    del summary["wall_s"]
    summary["energy"]["total"] = float("nan")
    summary["bodies"]["ball"]["centroid"] = [0, 0]
    summary["bodies"]["ball"]["velocity"] = [0, 0, float("inf")]
    summary["extra"]["ratio"] = [1.0, float("-inf")]
    problems = validate_summary(summary)
    assert problems == ["wall_s: missing", "energy.total: expected a finite number, got nan",
                        "bodies.ball.centroid: expected 3 finite numbers, got [0, 0]",
                        "bodies.ball.velocity: expected 3 finite numbers, got [0, 0, inf]",
                        "extra.ratio[1]: NaN or infinity has no JSON form"]
    with pytest.raises(ValueError, match="wall_s: missing"):
        write_summary(tmp_path, summary)
    assert not (tmp_path / "summary.json").exists()


def scalars(step):
    return {"time": 0.001 * step, "step": step, "dt": np.float64(1e-4), "frame": 3,
            "next_frame_time": float("inf"), "state": {"window": [1, 2, 3], "name": "w"}}


def test_checkpoint_round_trip(tmp_path):
    columns = particle_columns(11)
    path = save_checkpoint(tmp_path, COMM, scalars(12), columns)
    assert path == os.path.join(tmp_path, "checkpoint_000012.h5")
    assert latest_checkpoint(tmp_path) == path
    loaded_scalars, loaded = load_checkpoint(path, COMM)
    assert loaded_scalars == json.loads(json.dumps(scalars(12), default=float))
    assert list(loaded) == list(columns)
    for name, array in columns.items():
        assert loaded[name].dtype == array.dtype
        np.testing.assert_array_equal(loaded[name], array)


def test_checkpoint_keeps_newest_two(tmp_path):
    for step in (10, 20, 30):
        save_checkpoint(tmp_path, COMM, scalars(step), particle_columns(2))
    assert [step for step, _ in list_checkpoints(tmp_path)] == [20, 30]
    save_checkpoint(tmp_path, COMM, scalars(25), particle_columns(2))  # restarted from 20
    assert [step for step, _ in list_checkpoints(tmp_path)] == [20, 25]


def test_checkpoint_tmp_left_behind_is_not_latest(tmp_path):
    good = save_checkpoint(tmp_path, COMM, scalars(10), particle_columns(2))
    (tmp_path / "checkpoint_000020.h5.tmp").write_bytes(b"half a checkpoint")
    assert latest_checkpoint(tmp_path) == good
    save_checkpoint(tmp_path, COMM, scalars(30), particle_columns(2))
    assert not (tmp_path / "checkpoint_000020.h5.tmp").exists()
    assert latest_checkpoint(tmp_path).endswith("checkpoint_000030.h5")


def test_no_checkpoint_in_empty_or_missing_directory(tmp_path):
    assert latest_checkpoint(tmp_path) is None
    assert latest_checkpoint(tmp_path / "missing") is None
