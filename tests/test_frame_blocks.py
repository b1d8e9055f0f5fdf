"""Frames by body (issue 26): particles.h5 stores each frame's rows body-major with the
per-body counts in ``body_counts``, and particles.xdmf shows each frame as a multiblock of
one grid per body, named after it, that selects the body's rows with HyperSlabs. The
two-body case tests/cases/two_blocks.yaml (cubes ``left`` and ``right``, 8000 particles
each) on 1 rank and on 2 ranks cut along y, so that both ranks hold particles of both
bodies and rank-major rows would interleave the bodies."""
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from clihelp import CASES, run_ok
from xdmfread import dims, grid_arrays

CASE = f"{CASES}/two_blocks.yaml"
BODIES = ["left", "right"]
SHORT = ["--set", "time.end=0.0004", "--set", "output.frames=2",
         "--set", "decomposition.axis=y", "--quiet"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """{ranks: output directory} of the case on 1 and on 2 ranks."""
    out = {}
    for ranks in (1, 2):
        out[ranks] = tmp_path_factory.mktemp(f"blocks{ranks}")
        run_ok([CASE, "--out", out[ranks], *SHORT], ranks)
    return out


def frames(out):
    """The frame groups' data: [(attrs, {column: array})], in index order."""
    with h5py.File(out / "particles.h5", "r") as f:
        assert list(f.attrs["body_names"]) == BODIES
        return [(dict(f["frames"][k].attrs), {c: d[()] for c, d in f["frames"][k].items()})
                for k in sorted(f["frames"], key=int)]


def slab(item):
    """(start, count) per axis of a HyperSlab DataItem."""
    selector = item.findall("DataItem")[0]
    start, _, count = np.array(selector.text.split(), dtype=int).reshape(3, dims(selector)[1])
    return tuple(start), tuple(count)


@pytest.mark.parametrize("ranks", [1, 2])
def test_rows_are_grouped_by_body(runs, ranks):
    listed = frames(runs[ranks])
    assert len(listed) == 3
    for attrs, columns in listed:
        body = columns["body"]
        assert len(body) == attrs["n"] == 16000
        assert (np.diff(body) >= 0).all(), "rows not grouped by body"
        np.testing.assert_array_equal(attrs["body_counts"], np.bincount(body, minlength=2))
        np.testing.assert_array_equal(attrs["body_counts"], [8000, 8000])


@pytest.mark.parametrize("ranks", [1, 2])
def test_xdmf_has_one_grid_per_body_over_its_rows(runs, ranks):
    out = runs[ranks]
    steps = ET.parse(out / "particles.xdmf").getroot().findall("./Domain/Grid/Grid")
    with h5py.File(out / "particles.h5", "r") as f:
        names = sorted(f["frames"], key=int)
        assert len(steps) == len(names)
        for step, name in zip(steps, names):
            group = f["frames"][name]
            counts, n = group.attrs["body_counts"], int(group.attrs["n"])
            starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
            assert (step.get("GridType"), step.get("CollectionType")) == ("Collection", "Spatial")
            assert float(step.find("Time").get("Value")) == group.attrs["time"]
            grids = step.findall("Grid")
            assert [g.get("Name") for g in grids] == BODIES
            for b, grid in enumerate(grids):
                topology = grid.find("Topology")
                assert int(topology.get("NumberOfElements")) == counts[b]
                assert slab(topology.find("DataItem")) == ((0,), (counts[b],))
                assert slab(grid.find("Geometry/DataItem")) == ((starts[b], 0), (counts[b], 3))
                for attribute in grid.findall("Attribute"):
                    start, count = slab(attribute.find("DataItem"))
                    assert (start[0], count[0]) == (starts[b], counts[b]), attribute.get("Name")
                arrays = grid_arrays(grid, f)
                rows = slice(starts[b], starts[b] + counts[b])
                np.testing.assert_array_equal(arrays["topology"], np.arange(counts[b]))
                np.testing.assert_array_equal(arrays["geometry"], group["x"][rows])
                np.testing.assert_array_equal(arrays["id"], group["id"][rows])
                np.testing.assert_array_equal(arrays["szx"], group["stress"][rows, 5])
                assert (arrays["body"] == b).all()
                assert f[f"/xdmf/polyvertex_{n}"].shape == (n,)


def test_two_ranks_write_the_one_rank_frames(runs):
    """The same frames whatever the ranks, once each body's rows are sorted by id."""
    for (attrs1, one), (attrs2, two) in zip(frames(runs[1]), frames(runs[2]), strict=True):
        np.testing.assert_array_equal(attrs1["body_counts"], attrs2["body_counts"])
        assert set(one) == set(two)
        order1, order2 = np.argsort(one["id"]), np.argsort(two["id"])
        for name in one:
            a, b = one[name][order1], two[name][order2]
            if a.dtype.kind == "f":
                scale = max(float(np.abs(a).max()), 1e-300)
                np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12 * scale, err_msg=name)
            else:
                np.testing.assert_array_equal(b, a, err_msg=name)


def test_vtk_reads_the_bodies_as_named_blocks(runs):
    """Where VTK's Python module happens to be installed (it is not a dependency): its
    Xdmf3 reader gives a multiblock whose leaves are the bodies, by name and size."""
    vtk = pytest.importorskip("vtk")
    if not hasattr(vtk, "vtkXdmf3Reader"):
        pytest.skip("this VTK has no Xdmf3 reader")
    reader = vtk.vtkXdmf3Reader()
    reader.SetFileName(str(runs[2] / "particles.xdmf"))
    reader.Update()
    leaves = reader.GetOutputDataObject(0).NewTreeIterator()
    leaves.VisitOnlyLeavesOn()
    leaves.InitTraversal()
    found = []
    while not leaves.IsDoneWithTraversal():
        name = leaves.GetCurrentMetaData().Get(vtk.vtkCompositeDataSet.NAME())
        found.append((name, leaves.GetCurrentDataObject().GetNumberOfPoints()))
        leaves.GoToNextItem()
    assert found == [("left", 8000), ("right", 8000)]
