"""XDMF 3 description of the FEM frames (``DIR/elements.xdmf``), so that ParaView opens
elements.h5 as a time series of Hexahedron meshes: the connectivity ``/mesh/hexes``,
the node positions of each frame as geometry, node velocities, and per element the six
stress scalars (as in particles.xdmf), eps_p, density, e_int, damage, the hourglass energy,
the pressure and the von Mises stress (pmpm.io.derived)."""
from xml.sax.saxutils import quoteattr

from ._files import atomic_write_text
from .xdmf import STRESS_SCALARS, _column_slab, _data_item

CELL_SCALARS = ("eps_p", "density", "e_int", "damage", "hourglass_energy", "pressure",
                "von_mises")


def write_elements_xdmf(path, h5_name, frames, n_nodes, n_elements, real="<f8"):
    """Write ``path`` for ``frames``: a list of (group path, time, nodes, elements) in
    ``h5_name``; a frame whose counts differ from the mesh's (``n_nodes``,
    ``n_elements``: elements removed from the mesh) has its own connectivity;
    ``real``: the dtype of the floating-point datasets (output.precision)."""
    grids = "".join(_grid(h5_name, group, time, n, m,
                          (n, m) != (n_nodes, n_elements), real)
                    for group, time, n, m in frames)
    text = ('<?xml version="1.0" ?>\n<Xdmf Version="3.0">\n <Domain>\n'
            '  <Grid Name="elements" GridType="Collection" CollectionType="Temporal">\n'
            f"{grids}  </Grid>\n </Domain>\n</Xdmf>\n")
    atomic_write_text(path, text)


def _grid(h5, group, time, n, m, own_mesh=False, real="<f8", name=None):
    pad = "      "
    ref = f"{h5}:{group}"
    hexes = f"{ref}/hexes" if own_mesh else f"{h5}:/mesh/hexes"
    name = group.rsplit("/", 1)[-1] if name is None else name
    parts = [f'   <Grid Name={quoteattr(name)} GridType="Uniform">\n',
             f'    <Time Value="{float(time)!r}"/>\n',
             f'    <Topology TopologyType="Hexahedron" NumberOfElements="{m}" '
             f'NodesPerElement="8">\n',
             _data_item(hexes, (m, 8), "<i8", pad), "    </Topology>\n",
             '    <Geometry GeometryType="XYZ">\n',
             _data_item(f"{ref}/node_x", (n, 3), real, pad), "    </Geometry>\n",
             _attribute("velocity", "Vector", "Node",
                        _data_item(f"{ref}/node_v", (n, 3), real, pad)),
             _attribute("displacement", "Vector", "Node",
                        _data_item(f"{ref}/node_displacement", (n, 3), real, pad))]
    parts += [_attribute(label, "Scalar", "Cell",
                         _column_slab(f"{ref}/stress", m, 6, k, real, pad))
              for k, label in enumerate(STRESS_SCALARS)]
    parts += [_attribute(name, "Scalar", "Cell", _data_item(f"{ref}/{name}", (m,), real, pad))
              for name in CELL_SCALARS]
    return "".join(parts) + "   </Grid>\n"


def element_grid(h5_name, frame, n_nodes, n_elements, real="<f8", name="elements"):
    """The Uniform Hexahedron grid of one frame, ``frame`` = (group path, time, nodes,
    elements) as :func:`write_elements_xdmf` takes it, named ``name``."""
    group, time, n, m = frame
    return _grid(h5_name, group, time, n, m, (n, m) != (n_nodes, n_elements), real, name)


def _attribute(name, kind, center, body):
    return (f'    <Attribute Name={quoteattr(name)} AttributeType="{kind}" '
            f'Center="{center}">\n{body}    </Attribute>\n')
