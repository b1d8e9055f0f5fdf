"""The XDMF stays consistent with particles.h5 when frames hold no particles (issue 17):
one time step per frame, every HDF5 reference to an existing dataset of the dimensions
it declares, none to an empty one, on 1 and 2 ranks. (VTK's XDMF reader, tried by hand:
an error or a crash for an empty uniform grid, an empty data set for the empty
collection written instead.)"""
import xml.etree.ElementTree as ET

import h5py
import meshio
import pytest

from clihelp import BAR, frame_list, run_ok

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
    # meshio reads the mesh of the first step and the empty steps (it cannot read the
    # HyperSlab items of the stress scalars, so not the data of a step with particles)
    with meshio.xdmf.TimeSeriesReader(out / "particles.xdmf") as reader:
        points, cells = reader.read_points_cells()
        assert points.shape == (624, 3) and len(cells[0].data) == 624
        assert reader.num_steps == 5
        assert [reader.read_data(k)[:2] for k in range(1, 5)] == [(t, {}) for t, _ in frames[1:]]
