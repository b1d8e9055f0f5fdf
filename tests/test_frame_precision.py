"""output.precision: float32 frames (issue 26) for particles and elements, described as
such in the XDMF files, readable by pmpm.post, about half the disk; checkpoints stay
float64 so a restart gives the float64 run's answer."""
import os

import h5py
import numpy as np

from clihelp import BAR, BAR_HALF_END, CASES, run_ok
from pmpm.post import read_frame

STRIKER_FEM = os.path.join(CASES, "striker_on_fem_bar.yaml")


def float_dtypes(path):
    found = set()

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and name.startswith("frames/") \
                and obj.dtype.kind == "f":
            found.add(obj.dtype.str)
    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return found


def test_float32_particle_frames_are_half_and_read_back(tmp_path):
    full, half = tmp_path / "f64", tmp_path / "f32"
    run_ok([BAR, "--out", full, "--quiet"])
    run_ok([BAR, "--out", half, "--quiet", "--set", "output.precision=float32"])
    assert float_dtypes(half / "particles.h5") == {"<f4"}
    assert float_dtypes(full / "particles.h5") == {"<f8"}
    xdmf = (half / "particles.xdmf").read_text()
    assert 'NumberType="Float" Precision="4"' in xdmf and 'Precision="8"' not in xdmf.replace(
        'NumberType="Int" Precision="8"', "")
    a, b = read_frame(full, -1), read_frame(half, -1)
    assert b["x"].dtype == np.float32
    assert np.allclose(a["x"], b["x"], rtol=1e-6, atol=1e-6)
    assert np.array_equal(a["x"].astype(np.float32), b["x"])   # the same run, rounded
    assert os.path.getsize(half / "particles.h5") < 0.7 * os.path.getsize(full / "particles.h5")


def test_float32_frames_restart_exactly(tmp_path):
    full, cut = tmp_path / "full", tmp_path / "cut"
    run_ok([BAR, "--out", full, "--quiet", "--set", "output.precision=float32"])
    run_ok([BAR, "--out", cut, "--quiet", "--set", "output.precision=float32",
            "--set", f"time.end={BAR_HALF_END}"])
    run_ok([BAR, "--out", cut, "--quiet", "--restart", "--set", "output.precision=float32"])
    assert np.array_equal(read_frame(full, -1)["x"], read_frame(cut, -1)["x"])


def test_float32_element_frames(tmp_path):
    run_ok([STRIKER_FEM, "--out", tmp_path, "--quiet", "--set", "time.end=0.002",
            "--set", "output.times=[]",
            "--set", "output.precision=float32"])
    assert float_dtypes(tmp_path / "elements.h5") == {"<f4"}
    xdmf = (tmp_path / "elements.xdmf").read_text()
    assert 'NumberType="Float" Precision="4"' in xdmf
    assert 'NumberType="Float" Precision="8"' not in xdmf
