"""``DIR/bodies.xdmf``: with FEM bodies, the particles and the elements in one ParaView
time series (rank 0 writes it beside particles.xdmf and elements.xdmf, which stay).

Each frame is a Spatial collection (a multiblock) of the particle bodies' blocks, as
particles.xdmf has them (from particles.h5), and one block ``elements``, as elements.xdmf
has it (from elements.h5): elements that turn into particles (``fem.convert``) leave the
``elements`` block and their particles appear in their body's block in the same frame,
so one reader, one time slider and one colour map show both. A particle frame and an
element frame are paired by their time (the run writes both at every frame time); a
particle frame with no element frame at its time (an elements.h5 lost before a restart)
shows the particles alone.
"""
from ._files import atomic_write_text
from .elements_xdmf import element_grid
from .xdmf import body_grids, spatial_frame, xdmf_document

INDENT = "      "


class BodiesXdmf:
    """Keeps the frames' text, so rewriting the document after each frame does not build
    the earlier frames again."""

    def __init__(self, path):
        self.path, self.texts = path, []

    def write(self, particles, elements):
        """Rewrite ``self.path`` from the frames of ``particles``
        (pmpm.io.particles_h5.ParticleWriter) and ``elements``
        (pmpm.io.elements_h5.ElementWriter); rank 0 only, not collective."""
        frames = particles.frames
        if len(self.texts) > len(frames):          # a restart dropped frames
            self.texts = []
        by_time = {frame[1]: frame for frame in elements.written}
        p_name = particles.h5_name
        for frame in frames[len(self.texts):]:
            grids = body_grids(p_name, frame, particles.body_names, INDENT + "  ")
            element_frame = by_time.get(frame["time"])
            if element_frame is not None:
                grids += element_grid(elements.h5_name, element_frame, elements.n_nodes,
                                      elements.n_elements, elements.real_dtype)
            name = frame["group"].rstrip("/").rsplit("/", 1)[-1]
            self.texts.append(spatial_frame(name, frame["time"], grids, INDENT))
        atomic_write_text(self.path, xdmf_document(self.texts, "bodies"))
