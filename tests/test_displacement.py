"""The displacement field of the frames (issue 26): x - x0 for particles (x0: where the
particle was at the start, carried through migration, splitting and restarts) and for
FE nodes; zero in the first frame, the particle's own travel later, and its mass-weighted
mean the body's centroid displacement (exact also for particles split by a window)."""
import os

import h5py
import numpy as np

from clihelp import BAR, CASES, run_ok
from pmpm.post import read_frame, read_history

WINDOW = os.path.join(CASES, "window_follow.yaml")
STRIKER_FEM = os.path.join(CASES, "striker_on_fem_bar.yaml")


def test_particle_displacement_is_its_travel_from_the_start(tmp_path):
    run_ok([BAR, "--out", tmp_path, "--quiet"], 2)
    first, last = read_frame(tmp_path, 0), read_frame(tmp_path, -1)
    assert np.array_equal(first["displacement"], np.zeros_like(first["x"]))
    assert np.array_equal(first["id"], last["id"])
    assert np.allclose(last["displacement"], last["x"] - first["x"], rtol=0, atol=1e-12)
    assert np.abs(last["displacement"][:, 2]).max() > 0.1


def test_split_particles_keep_the_body_centroid_displacement(tmp_path):
    """The plate's particles that the moving window splits: the mass-weighted mean
    displacement of each body is its centroid's travel (history.csv)."""
    run_ok([WINDOW, "--out", tmp_path, "--quiet"])
    first, last = read_frame(tmp_path, 0), read_frame(tmp_path, -1)
    assert len(last["id"]) > len(first["id"])                 # particles were split
    hist = read_history(tmp_path)
    with h5py.File(tmp_path / "particles.h5", "r") as f:
        names = list(f.attrs["body_names"])
    for b, name in enumerate(names):
        mine = last["body"] == b
        m = last["mass"][mine]
        mean = (m[:, None] * last["displacement"][mine]).sum(axis=0) / m.sum()
        travel = [hist[f"{name}.{a}"][-1] - hist[f"{name}.{a}"][0] for a in "xyz"]
        assert np.allclose(mean, travel, rtol=1e-9, atol=1e-12), name


def test_fe_node_displacement_in_the_element_frames(tmp_path):
    run_ok([STRIKER_FEM, "--out", tmp_path, "--quiet", "--set", "time.end=0.01",
            "--set", "output.times=[]"])
    with h5py.File(tmp_path / "elements.h5", "r") as f:
        frames = [f["frames"][k] for k in sorted(f["frames"])]
        x0, x = frames[0]["node_x"][()], frames[-1]["node_x"][()]
        assert np.array_equal(frames[0]["node_displacement"][()], np.zeros_like(x0))
        assert np.allclose(frames[-1]["node_displacement"][()], x - x0, atol=1e-12)
        assert np.abs(x - x0).max() > 1e-3
    assert 'Name="displacement"' in (tmp_path / "elements.xdmf").read_text()
