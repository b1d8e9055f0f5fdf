"""What a frame carries beyond the state (issue 26): the pressure and the von Mises
stress, in particles.h5, elements.h5 and their XDMF; frames at a time interval
(``output.every``); runs without checkpoints (``output.checkpoints: false``)."""
import glob
import os

import h5py
import numpy as np
import pytest

from clihelp import BAR, CASES, run_ok
from pmpm.io.derived import stress_invariants
from pmpm.post import read_frame, read_history


def test_invariants_of_textbook_stresses():
    s = 250.0
    stress = np.array([[s, 0, 0, 0, 0, 0],           # uniaxial tension
                       [0, 0, 0, s, 0, 0],           # pure shear (tensor component)
                       [-s, -s, -s, 0, 0, 0],        # hydrostatic compression
                       [s, -s, 0, 0, 0, 0]])         # plane shear by normal stresses
    pressure, von_mises = stress_invariants(stress)
    assert pressure == pytest.approx([-s / 3, 0, s, 0], abs=1e-12)
    assert von_mises == pytest.approx([s, np.sqrt(3) * s, 0, np.sqrt(3) * s], abs=1e-12)


def test_particle_frames_carry_the_pressure_and_von_mises_stress(tmp_path):
    out = tmp_path / "out"
    run_ok([BAR, "--out", out, "--quiet"])
    frame = read_frame(out)
    pressure, von_mises = stress_invariants(frame["stress"])
    assert np.array_equal(frame["pressure"], pressure)
    assert np.array_equal(frame["von_mises"], von_mises)
    assert von_mises.max() > 100.0                  # the bar has yielded (A = 157 MPa)
    xdmf = (out / "particles.xdmf").read_text()
    assert 'Name="pressure"' in xdmf and 'Name="von_mises"' in xdmf


def test_element_frames_carry_the_pressure_and_von_mises_stress(tmp_path):
    out = tmp_path / "out"
    run_ok([os.path.join(CASES, "block_on_fem_plate.yaml"), "--out", out, "--quiet"])
    with h5py.File(out / "elements.h5", "r") as f:
        last = f["frames"][sorted(f["frames"])[-1]]
        pressure, von_mises = stress_invariants(last["stress"][()])
        assert np.array_equal(last["pressure"][()], pressure)
        assert np.array_equal(last["von_mises"][()], von_mises)
        assert np.abs(pressure).max() > 0.0             # the block has hit the plate
    xdmf = (out / "elements.xdmf").read_text()
    assert 'Name="pressure"' in xdmf and 'Name="von_mises"' in xdmf
    # the bodies' energies in history.csv add up to the totals (the plate's internal
    # energy holds its hourglass energy)
    hist = read_history(out)
    for kind in ("kinetic", "internal"):
        assert hist[f"block.{kind}"] + hist[f"plate.{kind}"] == pytest.approx(
            hist[kind], rel=1e-10, abs=1e-14)
    assert hist["plate.internal"][-1] > 0 and hist["block.internal"][-1] > 0


def frame_times(out):
    with h5py.File(os.path.join(out, "particles.h5"), "r") as f:
        return sorted(float(g.attrs["time"]) for g in f["frames"].values())


def test_frames_at_a_time_interval(tmp_path):
    """every = 0.0015 ms in a 0.005 ms run: 0.0015, 0.003, 0.0045 and the end, besides
    the initial state; with frames given too, their times join."""
    out = tmp_path / "every"
    run_ok([BAR, "--out", out, "--quiet", "--set", "output.every=0.0015",
            "--set", "output.times=[]"])
    assert frame_times(out) == pytest.approx([0.0, 0.0015, 0.003, 0.0045, 0.005],
                                             abs=1e-12)
    both = tmp_path / "both"
    run_ok([BAR, "--out", both, "--quiet", "--set", "output.every=0.002",
            "--set", "output.frames=4", "--set", "output.times=[]"])
    assert frame_times(both) == pytest.approx([0.0, 0.00125, 0.002, 0.0025, 0.00375,
                                               0.004, 0.005], abs=1e-12)


def test_a_run_without_checkpoints_writes_none(tmp_path):
    out = tmp_path / "out"
    run_ok([BAR, "--out", out, "--quiet", "--set", "output.checkpoints=false"])
    assert glob.glob(str(out / "checkpoint_*")) == []
    assert (out / "summary.json").exists()
