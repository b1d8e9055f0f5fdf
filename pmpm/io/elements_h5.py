"""Frames of the FEM bodies (``DIR/elements.h5``), beside particles.h5, at the same times,
and ``DIR/elements.xdmf`` that ParaView opens (pmpm.io.elements_xdmf).

File layout::

    /                     attrs: body_names, frames (count)
    /mesh/hexes (m, 8)    int64 node indices, VTK order; /mesh/body (m,) int32
    /frames/000000        attrs: time, step
        node_x (n,3) node_v (n,3)   node positions and half-step velocities
        hexes (m,8) body (m,)       only once elements have turned into particles
                                    (fem.convert): the frame's own connectivity, into
                                    its nodes; else /mesh's
        stress (m,6; attr components = "xx,yy,zz,xy,yz,zx") eps_p density e_int
        centroid (m,3) hourglass_energy (m,)

Rank 0 writes it: every rank sends it its owned nodes and its elements at each frame
(a gather; the collective parallel writer is still to come).
"""
import os

import h5py

from .elements_xdmf import write_elements_xdmf
from .particles_h5 import STRESS_COMPONENTS


class ElementWriter:
    """Writes element frames of a :class:`pmpm.solver.fem_bodies.FemBodies`; every
    method is collective (rank 0 writes)."""

    def __init__(self, path, elements, body_names, is_root, restart_frame=None):
        self.elements, self.path = elements, path
        self.count, self.written, self.file = 0, [], None
        if not is_root:
            return
        hexes, body, self.n_nodes = elements.output_mesh
        self.n_elements = len(hexes)
        if restart_frame is not None and os.path.exists(path):
            self.continue_file(restart_frame)
            return
        self.file = h5py.File(path, "w")
        self.file.attrs["body_names"] = list(body_names)
        self.file.create_dataset("mesh/hexes", data=hexes)
        self.file.create_dataset("mesh/body", data=body)
        self.file["mesh"].attrs["n_nodes"] = self.n_nodes
        self.frames = self.file.create_group("frames")

    def continue_file(self, restart_frame):
        """After --restart: keep the frames written before the checkpoint, drop later
        ones (the restarted run writes them again)."""
        self.file = h5py.File(self.path, "a")
        self.frames = self.file["frames"]
        # the mesh the file began with: a checkpoint taken after conversions holds fewer
        self.n_elements = len(self.file["mesh/hexes"])
        self.n_nodes = int(self.file["mesh"].attrs.get("n_nodes", self.n_nodes))
        for name in sorted(self.frames):
            if int(name) >= restart_frame:
                del self.frames[name]
            else:
                frame = self.frames[name]
                self.written.append((frame.name, float(frame.attrs["time"]),
                                     len(frame["node_x"]), len(frame["eps_p"])))
        self.count = len(self.written)

    def write_frame(self, time, step):
        columns = self.elements.frame()
        self.count += 1
        if not self.file:
            return
        group = self.frames.create_group(f"{self.count - 1:06d}")
        group.attrs["time"], group.attrs["step"] = float(time), int(step)
        hexes, body = columns.pop("hexes"), columns.pop("body")
        sizes = (len(columns["node_x"]), len(hexes))
        if sizes != (self.n_nodes, self.n_elements):   # elements have become particles
            group.create_dataset("hexes", data=hexes)
            group.create_dataset("body", data=body)
        for name, column in columns.items():
            group.create_dataset(name, data=column)
        group["stress"].attrs["components"] = STRESS_COMPONENTS
        self.file.attrs["frames"] = self.count
        self.file.flush()
        self.written.append((group.name, float(time), *sizes))
        write_elements_xdmf(os.path.splitext(self.path)[0] + ".xdmf",
                            os.path.basename(self.path), self.written, self.n_nodes,
                            self.n_elements)

    def close(self):
        if self.file:
            self.file.close()
            self.file = None
