"""The XDMF stays consistent with particles.h5 when frames hold no particles (issue 17):
one time step per frame, every HDF5 reference to an existing dataset of the dimensions
it declares, none to an empty one, on 1 and 2 ranks. (VTK's XDMF reader, tried by hand:
an error or a crash for an empty uniform grid, an empty data set for the empty
collection written instead.)"""
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from clihelp import BAR, frame_list, run_ok
from xdmfread import grid_arrays

# every particle leaves the grid box in the first step, and the case allows it
GONE = ["--set", "gravity=[0, 0, -1e12]", "--set", "grid.lost_mass_fraction=1",
        "--set", "output.frames=4", "--set", "output.times=[]"]


def hdf_items(root):
    """(path in the file, declared dimensions) of every HDF DataItem, slab operands too."""
    for item in root.iter("DataItem"):
        if item.get("Format") == "HDF":
            name, path = item.text.strip().split(":", 1)
            assert name == "particles.h5"
            yield path, tuple(int(d) for d in item.get("Dimensions").split())


@pytest.mark.parametrize("ranks", [1, 2])
def test_frames_of_no_particles_keep_the_xdmf_consistent(tmp_path, ranks):
    out = tmp_path / "out"
    run_ok([BAR, "--out", out, "--quiet", *GONE], ranks)
    frames = frame_list(out)
    assert len(frames) == 5
    with h5py.File(out / "particles.h5", "r") as f:
        counts = [int(f["frames"][name].attrs["n"]) for name in sorted(f["frames"], key=int)]
        root = ET.parse(out / "particles.xdmf").getroot()
        steps = root.findall("./Domain/Grid/Grid")
        assert [float(g.find("Time").get("Value")) for g in steps] == [t for t, _ in frames]
        assert counts == [624, 0, 0, 0, 0]
        references = list(hdf_items(root))
        assert references, "no HDF reference at all"
        for path, dims in references:
            assert path in f, f"{path} is not in particles.h5"
            assert f[path].shape == dims, (path, f[path].shape, dims)
            assert 0 not in dims, f"{path}: an empty dataset referenced"
        # the first step's blocks resolve to its particles; the empty steps hold none
        blocks = steps[0].findall("Grid")
        assert blocks and all(not step.findall("Grid") for step in steps[1:])
        points = np.concatenate([grid_arrays(grid, f)["geometry"] for grid in blocks])
        np.testing.assert_array_equal(points, f["frames/000000/x"][()])
