"""XDMF 3 description of the particle frames, so that ParaView opens particles.h5 as a time series.

Each frame becomes a Spatial collection (a multiblock in ParaView) in a Temporal
collection, with one Uniform grid per body that has particles, named after the body, so
that ParaView's Multiblock Inspector, *Extract Block* and colouring by block show the
bodies by name (XDMF has no string attribute to carry them per point). A body's grid is
its range of the frame's rows, which particles.h5 stores body-major (the frame attribute
``body_counts``): Polyvertex topology (one vertex cell per particle), XYZ geometry from
``GROUP/x`` and one Node-centred attribute per column, each a HyperSlab of its rows, so
no data is copied. A frame without ``body_counts`` (written before the layout was
body-major) is one Uniform grid of all its rows.

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
distinct particle count by :class:`pmpm.io.particles_h5.ParticleWriter`); a body's grid
takes its first ``count`` entries, ``0 .. count-1``.

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


def _slab(ref, shape, start, count, dtype, indent):
    """A HyperSlab DataItem selecting ``count`` entries per axis from ``start`` (stride 1)
    of the HDF5 dataset ``ref`` of ``shape``."""
    selector = " ".join(str(v) for v in (*start, *(1,) * len(shape), *count))
    dims = " ".join(str(c) for c in count)
    return (f'{indent}<DataItem ItemType="HyperSlab" Dimensions="{dims}" Type="HyperSlab">\n'
            f'{indent}  <DataItem Dimensions="3 {len(shape)}" NumberType="Int" Format="XML">'
            f"{selector}</DataItem>\n"
            + _data_item(ref, shape, dtype, indent + "  ")
            + f"{indent}</DataItem>\n")


def _column_slab(ref, n, width, component, dtype, indent, rows=None):
    """A HyperSlab DataItem selecting column ``component`` of an (n, width) dataset, of the
    rows ``rows`` = (start, count) (default all)."""
    start, count = rows or (0, n)
    return _slab(ref, (n, width), (start, component), (count, 1), dtype, indent)


def _rows_item(ref, shape, rows, dtype, indent):
    """The rows ``rows`` = (start, count) of the dataset ``ref`` of ``shape`` as a HyperSlab,
    or the whole dataset when ``rows`` is None."""
    if rows is None:
        return _data_item(ref, shape, dtype, indent)
    trailing = tuple(shape[1:])
    return _slab(ref, shape, (rows[0],) + (0,) * len(trailing), (rows[1],) + trailing,
                 dtype, indent)


def _attribute(name, kind, body, indent):
    return (f'{indent}<Attribute Name={quoteattr(name)} AttributeType="{kind}" Center="Node">\n'
            f"{body}{indent}</Attribute>\n")


def _component_names(name, width):
    if name == "stress" and width == 6:
        return STRESS_SCALARS
    if width == 6:
        return tuple(f"{name}_{c}" for c in VOIGT)
    return tuple(f"{name}_{k}" for k in range(width))


def _attributes(h5_name, group, n, name, dtype, width, indent, rows=None):
    """Attribute elements for one column: Scalar, Vector, Tensor, or one Scalar per
    component; of the rows ``rows`` = (start, count) only, when given."""
    ref = f"{h5_name}:{group}/{name}"
    inner = indent + "  "
    if width == 1:
        return _attribute(name, "Scalar", _rows_item(ref, (n,), rows, dtype, inner), indent)
    if width in (3, 9):
        kind = "Vector" if width == 3 else "Tensor"
        return _attribute(name, kind, _rows_item(ref, (n, width), rows, dtype, inner), indent)
    return "".join(
        _attribute(label, "Scalar", _column_slab(ref, n, width, k, dtype, inner, rows), indent)
        for k, label in enumerate(_component_names(name, width)))


def _grid(h5_name, frame, indent, name=None, rows=None):
    """The Uniform grid element of one frame (with its time), or, given ``name`` and
    ``rows`` = (start, count), of that range of its rows (no time: its collection has it)."""
    group, n = frame["group"].rstrip("/"), int(frame["n"])
    columns = frame.get("columns", STANDARD_COLUMNS)
    topology = frame.get("topology", topology_path(n))
    index_dtype = "<i4" if n < 2**31 else "<i8"
    count = n if rows is None else rows[1]
    inner = indent + "  "
    text = f'{indent}<Grid Name={quoteattr(name or group.rsplit("/", 1)[-1])} GridType="Uniform">\n'
    if rows is None:
        text += f'{inner}<Time Value="{float(frame["time"])!r}"/>\n'
        connectivity = _data_item(f"{h5_name}:{topology}", (n,), index_dtype, inner + "  ")
    else:
        connectivity = _slab(f"{h5_name}:{topology}", (n,), (0,), (count,), index_dtype,
                             inner + "  ")
    text += (f'{inner}<Topology TopologyType="Polyvertex" NumberOfElements="{count}" '
             f'NodesPerElement="1">\n{connectivity}{inner}</Topology>\n'
             f'{inner}<Geometry GeometryType="XYZ">\n'
             + _rows_item(f"{h5_name}:{group}/x", (n, 3), rows, columns["x"][0], inner + "  ")
             + f"{inner}</Geometry>\n")
    for column, (dtype, width) in columns.items():
        if column != "x":
            text += _attributes(h5_name, group, n, column, dtype, int(width), inner, rows)
    return text + f"{indent}</Grid>\n"


def body_name(names, index):
    """The name of body ``index``: ``names[index]``, or ``body_INDEX`` past their end."""
    return str(names[index]) if index < len(names) else f"body_{index}"


def body_grids(h5_name, frame, names, indent):
    """The Uniform grids of a frame's bodies with particles, each named after its body,
    over its range of rows (body-major); "" for a frame of no particles, and a frame
    without ``body_counts`` as one grid (with its time)."""
    if int(frame["n"]) == 0:
        return ""
    if frame.get("body_counts") is None:
        return _grid(h5_name, frame, indent)
    counts = [int(c) for c in frame["body_counts"]]
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int)
    return "".join(_grid(h5_name, frame, indent, body_name(names, b),
                         (int(starts[b]), count))
                   for b, count in enumerate(counts) if count > 0)


def spatial_frame(name, time, grids, indent):
    """A frame as a Spatial collection (a multiblock in ParaView) of ``grids``, with its
    time."""
    return (f'{indent}<Grid Name={quoteattr(name)} GridType="Collection" '
            f'CollectionType="Spatial">\n'
            f'{indent}  <Time Value="{float(time)!r}"/>\n'
            f"{grids}{indent}</Grid>\n")


def _blocks(h5_name, frame, names, indent):
    """A frame as a Spatial collection of one Uniform grid per body with particles."""
    name = frame["group"].rstrip("/").rsplit("/", 1)[-1]
    return spatial_frame(name, frame["time"],
                         body_grids(h5_name, frame, names, indent + "  "), indent)


def _empty_grid(frame, indent):
    """A frame of no particles: its time in an empty spatial collection (module notes)."""
    name = frame["group"].rstrip("/").rsplit("/", 1)[-1]
    return spatial_frame(name, frame["time"], "", indent)


def _frame(h5_name, frame, names, indent):
    """The element of one frame: empty, by body, or (no ``body_counts``) one grid."""
    if int(frame["n"]) == 0:
        return _empty_grid(frame, indent)
    if frame.get("body_counts") is not None:
        return _blocks(h5_name, frame, names, indent)
    return _grid(h5_name, frame, indent)


def frame_text(h5_name, frame, body_names=()):
    """The XDMF element of one frame (see :func:`write_xdmf`): a writer keeps it, so that
    rewriting the document after each frame does not rebuild the earlier ones."""
    return _frame(h5_name, frame, list(body_names), "      ")


def xdmf_text(h5_name, frames, body_names=()):
    """The XDMF document for ``frames`` (see :func:`write_xdmf`) as a string."""
    return xdmf_document([frame_text(h5_name, frame, body_names) for frame in frames])


def xdmf_document(frame_texts, name="particles"):
    """The XDMF document around the frames' elements (:func:`frame_text`), in time order:
    a Temporal collection named ``name``."""
    grids = "".join(frame_texts)
    return ('<?xml version="1.0" encoding="utf-8"?>\n'
            '<Xdmf Version="3.0" xmlns:xi="http://www.w3.org/2001/XInclude">\n'
            "  <Domain>\n"
            f'    <Grid Name={quoteattr(name)} GridType="Collection" CollectionType="Temporal">\n'
            f"{grids}"
            "    </Grid>\n"
            "  </Domain>\n"
            "</Xdmf>\n")


def write_xdmf(xdmf_path, h5_name, frames, body_names=()):
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
        :func:`topology_path`), and ``body_counts`` (particles per body, rows body-major;
        without it the frame is one grid of all its rows). A frame with ``n == 0`` is an
        empty collection with its time (see the module notes).
    body_names : sequence of str, optional
        Names of the bodies by index, for the blocks' names (``body_N`` past the end).

    Notes
    -----
    Columns with one component become Scalar attributes, three a Vector, nine a Tensor;
    ``stress`` becomes six Scalars ``sxx .. szx`` (see the module notes for why), and any
    other width one Scalar per component.
    """
    atomic_write_text(xdmf_path, xdmf_text(h5_name, frames, body_names))
