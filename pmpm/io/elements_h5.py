"""Frames of the FEM bodies (``DIR/elements.h5``), beside particles.h5, at the same times,
written collectively by all ranks, and ``DIR/elements.xdmf`` that ParaView opens
(pmpm.io.elements_xdmf).

File layout::

    /                     attrs: body_names, frames (count), ranks
    /mesh/hexes (m, 8)    int64 node rows of the elements when the file was made, VTK order
    /mesh/body (m,)       int32; attr n_nodes: the node count that /mesh/hexes indexes
    /frames/000000        attrs: time, step
        node_id (n,) int64, node_x (n,3), node_v (n,3)
                          global node ids, positions and half-step velocities
        element_id (m,) int64
        hexes (m,8) body (m,)   only once the alive elements are fewer than /mesh's
                                (some were removed from the mesh): the frame's own
                                connectivity, into its node rows; else /mesh's
        stress (m,6; attr components = "xx,yy,zz,xy,yz,zx") eps_p density e_int
        damage (0 intact .. 1 failed) centroid (m,3) hourglass_energy (m,)

Node rows are in ascending node id, element rows in ascending element id, whatever ranks
hold them (pmpm.io._by_id): the file is the same, row for row, on any number of ranks.
Until an element is removed, ids are ``0 .. n-1`` and ``0 .. m-1`` and row = id;
after, the ids that are gone leave no row (a frame holds the elements alive, whatever
removed the others). A node that several ranks hold is sent once, by the
lowest of them (the rank that counts it in sums, ``FemBodies.owned``).

Every rank writes its share with collective MPI-IO (pmpm.io._collective): each sends
its counted nodes and its elements to the rank that keeps their block of ids (one
all-to-all per kind); once ids are missing the ranks also ask the keepers for the rows
of the nodes their elements use (before, row = id); each then writes one contiguous
block of rows. No rank gathers a frame or
holds the whole mesh; /mesh is written the same way when the file is created.
"""
import os
import sys

import h5py
import numpy as np

from . import _by_id as B
from . import _collective as C
from .derived import PRECISIONS, in_precision, with_stress_invariants
from .elements_xdmf import write_elements_xdmf
from .particles_h5 import STRESS_COMPONENTS


def laid_out(comm, nodes, elements):
    """The frame columns ``nodes`` and ``elements`` of this rank (FemBodies.frame) turned
    into this rank's rows of the file: nodes by ``node_id`` and elements by
    ``element_id`` (each kept block sorted), ``hexes`` as rows of the file's nodes
    (collective)."""
    node_bound = B.id_bound(comm, nodes["node_id"])
    ids, nodes = B.to_keepers(comm, nodes["node_id"], nodes, node_bound)
    elements = dict(elements, hexes=node_rows(comm, elements["hexes"], ids, node_bound))
    element_bound = B.id_bound(comm, elements["element_id"])
    _, elements = B.to_keepers(comm, elements["element_id"], elements, element_bound)
    return nodes, elements


def node_rows(comm, corners, kept, bound):
    """The file rows of the node ids ``corners`` (kept: the ids this rank keeps, sorted):
    the ids themselves while every id below ``bound`` is in the file (no element has
    been removed), else asked of the keepers (collective)."""
    if comm.allreduce(len(kept)) == bound:
        return corners
    used, inverse = np.unique(corners, return_inverse=True)
    rows = B.rows_of(comm, used, kept, B.first_row(comm, len(kept)), bound)
    return rows[inverse].reshape(corners.shape)


def totals(comm, nodes, elements):
    """(nodes, elements) over all ranks."""
    counts = comm.allgather((len(nodes["node_id"]), len(elements["element_id"])))
    return tuple(int(n) for n in np.sum(counts, axis=0))


def write_laid_out(group, comm, columns):
    """Datasets of ``group`` from every rank's laid-out ``columns`` (collective); returns
    the global row count."""
    layout = C.agree_layout(comm, columns)
    datasets = C.create_columns(group, layout)
    if "stress" in datasets:
        datasets["stress"].attrs["components"] = STRESS_COMPONENTS
    C.write_columns(datasets, layout, comm.rank, columns)
    return layout.total


class ElementWriter:
    """Writes element frames of a :class:`pmpm.solver.fem_bodies.FemBodies`; every
    method is collective over ``comm`` (the raw mpi4py communicator of the run).

    ``restart_frame``: continue an existing file after --restart, keeping the frames
    before that index (see :meth:`continue_file`); a new file if there is none."""

    def __init__(self, path, elements, body_names, comm, restart_frame=None,
                 precision="float64"):
        self.elements, self.path, self.comm = elements, path, comm
        self.precision = precision
        self.count, self.written = 0, []
        if restart_frame is not None and C.bcast_root(comm, os.path.exists(path)):
            self.file = h5py.File(path, "r+", driver="mpio", comm=comm)
            self.continue_file(restart_frame)
            return
        if restart_frame is not None and comm.rank == 0:
            sys.stderr.write(f"pmpm: warning: --restart: {path} is missing; the element "
                             f"frames from the checkpoint on go to a new file\n")
            sys.stderr.flush()
        self.file = h5py.File(path, "w", driver="mpio", comm=comm)
        self.file.attrs["body_names"] = list(body_names)
        self.file.attrs["ranks"] = comm.size
        self.file.attrs["frames"] = 0
        self.write_mesh()
        self.frames = self.file.create_group("frames")

    @property
    def h5_name(self):
        """The file's bare name, as the XDMF documents refer to it."""
        return os.path.basename(self.path)

    @property
    def real_dtype(self):
        """The dtype string of the floating-point datasets (output.precision)."""
        return np.dtype(PRECISIONS[self.precision]).str

    def write_mesh(self):
        """/mesh: the connectivity and bodies of the elements as they are now."""
        nodes, elements = self.elements.frame()
        nodes, elements = laid_out(self.comm, nodes, with_stress_invariants(elements))
        mesh = self.file.create_group("mesh")
        self.n_elements = write_laid_out(
            mesh, self.comm, {"hexes": elements["hexes"], "body": elements["body"]})
        self.n_nodes = totals(self.comm, nodes, elements)[0]
        mesh.attrs["n_nodes"] = self.n_nodes

    def continue_file(self, restart_frame):
        """After --restart: keep the frames written before the checkpoint, drop later
        ones (the restarted run writes them again)."""
        self.frames = self.file["frames"]
        # the mesh the file began with: a checkpoint taken after removals holds fewer
        self.n_elements = len(self.file["mesh/hexes"])
        self.n_nodes = int(self.file["mesh"].attrs["n_nodes"])
        for name in sorted(self.frames):
            if int(name) >= restart_frame:
                del self.frames[name]
            else:
                frame = self.frames[name]
                self.written.append((frame.name, float(frame.attrs["time"]),
                                     len(frame["node_x"]), len(frame["eps_p"])))
        self.count = len(self.written)
        self.file.attrs["frames"] = self.count
        self.file.attrs["ranks"] = self.comm.size      # of the run that writes on

    def write_frame(self, time, step):
        """Write the elements and nodes of every rank as the next frame, then the XDMF
        (rank 0)."""
        nodes, elements = self.elements.frame()
        nodes, elements = laid_out(self.comm, nodes, with_stress_invariants(elements))
        nodes = in_precision(nodes, self.precision)
        elements = in_precision(elements, self.precision)
        sizes = totals(self.comm, nodes, elements)
        if sizes == (self.n_nodes, self.n_elements):   # every element is alive
            del elements["hexes"], elements["body"]
        time, step = C.bcast_root(self.comm, (float(time), int(step)))
        group = self.frames.create_group(f"{self.count:06d}")
        group.attrs["time"], group.attrs["step"] = time, step
        write_laid_out(group, self.comm, nodes)
        write_laid_out(group, self.comm, elements)
        self.count += 1
        self.file.attrs["frames"] = self.count
        self.file.flush()
        self.written.append((group.name, time, *sizes))
        if self.comm.rank == 0:
            write_elements_xdmf(os.path.splitext(self.path)[0] + ".xdmf", self.h5_name,
                                self.written, self.n_nodes, self.n_elements,
                                self.real_dtype)

    def close(self):
        if self.file:
            self.file.close()
            self.file = None
