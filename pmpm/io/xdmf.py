"""XDMF 3 description of the particle frames, so that ParaView opens particles.h5 as a time series.

Each frame becomes a Uniform grid of ``n`` points in a Temporal collection: Polyvertex
topology (one vertex cell per particle), XYZ geometry from ``GROUP/x``, and one Node-centred
attribute per column.

Notes
-----
Stress is exposed as six Scalar attributes ``sxx, syy, szz, sxy, syz, szx``, each a
HyperSlab (one column) of the ``GROUP/stress`` (n, 6) dataset, not as one ``Tensor6``
attribute. XDMF's Tensor6 order is xx, xy, xz, yy, yz, zz, and ParaView's two readers treat
it differently: the XDMF (2) reader expands it to nine components in that order, while the
Xdmf3 readers pass the six values through unchanged and VTK then labels them in its own
symmetric order XX, YY, ZZ, XY, YZ, XZ. No single Tensor6 layout is right in both; six
named scalars are right in every reader and cost no extra storage.

Xdmf3 builds no cells for a Polyvertex topology without connectivity, so the topology
refers to an index dataset ``0 .. n-1`` (``/xdmf/polyvertex_N`` by default, written once per
distinct particle count by :class:`pmpm.io.particles_h5.ParticleWriter`).

A frame with no particles (every particle left the grid box) is listed with its time, as
an empty spatial collection that refers to no dataset: the collection keeps one time step
per frame of particles.h5. VTK's XDMF reader (ParaView's *XDMF Reader*) fails on a
uniform grid of no points, however spelt (zero-size HDF5 or XML geometry: an error per
time step; no geometry or no topology: a crash); it reads the empty collection as an empty
data set, with a warning that its type differs from the other steps'.
"""
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from ._files import atomic_write_text

#: Columns of a frame under the run contract, as (numpy dtype string, components).
STANDARD_COLUMNS = {
    "x": ("<f8", 3), "v": ("<f8", 3), "stress": ("<f8", 6), "eps_p": ("<f8", 1),
    "density": ("<f8", 1), "mass": ("<f8", 1), "body": ("<i4", 1), "id": ("<i8", 1),
}
#: Names of the six stress scalars, in the stored (Voigt) order xx, yy, zz, xy, yz, zx.
STRESS_SCALARS = ("sxx", "syy", "szz", "sxy", "syz", "szx")
VOIGT = ("xx", "yy", "zz", "xy", "yz", "zx")


def topology_path(n):
    """Default HDF5 path of the index dataset ``0 .. n-1`` used as Polyvertex connectivity."""
    return f"/xdmf/polyvertex_{n}"


def number_type(dtype):
    """XDMF ``NumberType`` and ``Precision`` of a numpy dtype.

    Examples
    --------
    >>> number_type("<i8")
    ('Int', 8)
    """
    dtype = np.dtype(dtype)
    if dtype.kind == "f":
        return "Float", dtype.itemsize
    if dtype.kind == "i":
        return ("Char" if dtype.itemsize == 1 else "Int"), dtype.itemsize
    if dtype.kind in "ub":
        return ("UChar" if dtype.itemsize == 1 else "UInt"), dtype.itemsize
    raise ValueError(f"no XDMF number type for dtype {dtype}")


def _data_item(ref, dims, dtype, indent):
    kind, precision = number_type(dtype)
    dims = " ".join(str(d) for d in dims)
    return (f'{indent}<DataItem Dimensions="{dims}" NumberType="{kind}" Precision="{precision}" '
            f'Format="HDF">{escape(ref)}</DataItem>\n')


def _column_slab(ref, n, width, component, dtype, indent):
    """A HyperSlab DataItem selecting column ``component`` of an (n, width) dataset."""
    selector = f"0 {component} 1 1 {n} 1"
    return (f'{indent}<DataItem ItemType="HyperSlab" Dimensions="{n} 1" Type="HyperSlab">\n'
            f'{indent}  <DataItem Dimensions="3 2" NumberType="Int" Format="XML">'
            f"{selector}</DataItem>\n"
            + _data_item(ref, (n, width), dtype, indent + "  ")
            + f"{indent}</DataItem>\n")


def _attribute(name, kind, body, indent):
    return (f'{indent}<Attribute Name={quoteattr(name)} AttributeType="{kind}" Center="Node">\n'
            f"{body}{indent}</Attribute>\n")


def _component_names(name, width):
    if name == "stress" and width == 6:
        return STRESS_SCALARS
    if width == 6:
        return tuple(f"{name}_{c}" for c in VOIGT)
    return tuple(f"{name}_{k}" for k in range(width))


def _attributes(h5_name, group, n, name, dtype, width, indent):
    """Attribute elements for one column: Scalar, Vector, Tensor, or one Scalar per component."""
    ref = f"{h5_name}:{group}/{name}"
    inner = indent + "  "
    if width == 1:
        return _attribute(name, "Scalar", _data_item(ref, (n,), dtype, inner), indent)
    if width in (3, 9):
        kind = "Vector" if width == 3 else "Tensor"
        return _attribute(name, kind, _data_item(ref, (n, width), dtype, inner), indent)
    return "".join(
        _attribute(label, "Scalar", _column_slab(ref, n, width, k, dtype, inner), indent)
        for k, label in enumerate(_component_names(name, width)))


def _grid(h5_name, frame, indent):
    """The Uniform grid element of one frame."""
    group, n = frame["group"].rstrip("/"), int(frame["n"])
    columns = frame.get("columns", STANDARD_COLUMNS)
    topology = frame.get("topology", topology_path(n))
    index_dtype = "<i4" if n < 2**31 else "<i8"
    inner = indent + "  "
    text = (f'{indent}<Grid Name={quoteattr(group.rsplit("/", 1)[-1])} GridType="Uniform">\n'
            f'{inner}<Time Value="{float(frame["time"])!r}"/>\n'
            f'{inner}<Topology TopologyType="Polyvertex" NumberOfElements="{n}" NodesPerElement="1">\n'
            + _data_item(f"{h5_name}:{topology}", (n,), index_dtype, inner + "  ")
            + f"{inner}</Topology>\n"
            f'{inner}<Geometry GeometryType="XYZ">\n'
            + _data_item(f"{h5_name}:{group}/x", (n, 3), columns["x"][0], inner + "  ")
            + f"{inner}</Geometry>\n")
    for name, (dtype, width) in columns.items():
        if name != "x":
            text += _attributes(h5_name, group, n, name, dtype, int(width), inner)
    return text + f"{indent}</Grid>\n"


def _empty_grid(frame, indent):
    """A frame of no particles: its time in an empty spatial collection (module notes)."""
    name = frame["group"].rstrip("/").rsplit("/", 1)[-1]
    return (f'{indent}<Grid Name={quoteattr(name)} GridType="Collection" '
            f'CollectionType="Spatial">\n'
            f'{indent}  <Time Value="{float(frame["time"])!r}"/>\n'
            f"{indent}</Grid>\n")


def xdmf_text(h5_name, frames):
    """The XDMF document for ``frames`` (see :func:`write_xdmf`) as a string."""
    grids = "".join(_grid(h5_name, frame, "      ") if int(frame["n"]) > 0
                    else _empty_grid(frame, "      ") for frame in frames)
    return ('<?xml version="1.0" encoding="utf-8"?>\n'
            '<Xdmf Version="3.0" xmlns:xi="http://www.w3.org/2001/XInclude">\n'
            "  <Domain>\n"
            '    <Grid Name="particles" GridType="Collection" CollectionType="Temporal">\n'
            f"{grids}"
            "    </Grid>\n"
            "  </Domain>\n"
            "</Xdmf>\n")


def write_xdmf(xdmf_path, h5_name, frames):
    """Write the XDMF file describing the particle frames (rank 0 only; not collective).

    Parameters
    ----------
    xdmf_path : str or os.PathLike
        File to write, e.g. ``DIR/particles.xdmf``. Replaced atomically, so a reader or a
        crash never sees half a file.
    h5_name : str
        The HDF5 file as the XDMF refers to it, normally its bare name (``particles.h5``)
        so that the output directory can be moved.
    frames : list of dict
        One dict per frame, in time order, with keys ``group`` (``/frames/000003``),
        ``time`` and ``n`` (global particle count), and optionally ``columns`` (dict of
        name to (numpy dtype string, components); default :data:`STANDARD_COLUMNS`) and
        ``topology`` (HDF5 path of the index dataset ``0 .. n-1``; default
        :func:`topology_path`). A frame with ``n == 0`` is an empty collection with its
        time (see the module notes).

    Notes
    -----
    Columns with one component become Scalar attributes, three a Vector, nine a Tensor;
    ``stress`` becomes six Scalars ``sxx .. szx`` (see the module notes for why), and any
    other width one Scalar per component.
    """
    atomic_write_text(xdmf_path, xdmf_text(h5_name, frames))
