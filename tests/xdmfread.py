"""Resolve the DataItems of particles.xdmf against particles.h5 as an XDMF reader does
(HDF items and HyperSlabs of them), checking each declared Dimensions on the way; ``h5``
is the open particles.h5, or {file name: open file} for a document that reads several
(bodies.xdmf)."""
import numpy as np


def dims(item):
    """The declared Dimensions of a DataItem, as a tuple of int."""
    return tuple(int(d) for d in item.get("Dimensions").split())


def item_array(item, h5):
    """The array a DataItem stands for: an HDF dataset of ``h5`` (an open h5py.File) or a
    HyperSlab (start, stride, count per axis) of another item."""
    if item.get("ItemType") == "HyperSlab":
        selector, source = item.findall("DataItem")
        rank = dims(selector)[1]
        start, stride, count = np.array(selector.text.split(), dtype=int).reshape(3, rank)
        data = item_array(source, h5)
        assert len(data.shape) == rank
        assert all(a + s * (c - 1) < n for a, s, c, n in zip(start, stride, count, data.shape))
        out = data[tuple(slice(a, a + s * c, s) for a, s, c in zip(start, stride, count))]
    else:
        assert item.get("Format") == "HDF"
        name, path = item.text.strip().split(":", 1)
        if isinstance(h5, dict):
            out = h5[name][path][()]
        else:
            assert name == "particles.h5"
            out = h5[path][()]
    assert out.shape == dims(item), (item.text, out.shape, dims(item))
    return out


def grid_arrays(grid, h5):
    """{"topology", "geometry", then each attribute's name: array} of a Uniform grid; a
    scalar attribute declared (count, 1) comes back as (count,)."""
    topology, geometry = grid.find("Topology"), grid.find("Geometry")
    arrays = {"topology": item_array(topology.find("DataItem"), h5),
              "geometry": item_array(geometry.find("DataItem"), h5)}
    assert len(arrays["topology"]) == int(topology.get("NumberOfElements"))
    for attribute in grid.findall("Attribute"):
        data = item_array(attribute.find("DataItem"), h5)
        if attribute.get("AttributeType") == "Scalar" and data.ndim == 2:
            data = data[:, 0]
        arrays[attribute.get("Name")] = data
    return arrays
