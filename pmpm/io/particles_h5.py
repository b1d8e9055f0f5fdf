"""Collective HDF5 writer of particle frames (``DIR/particles.h5``) and its XDMF companion.

File layout::

    /                     attrs: frames (count), body_names, ranks, software, run_stats
                                 (JSON, at close), and the caller's attrs
    /case                 scalar UTF-8 string: the case file text
    /frames/000000        attrs: time, step, n (global particle count),
                                 body_counts (particles of each body, in body index order)
        x (n,3) v (n,3) stress (n,6; attr components = "xx,yy,zz,xy,yz,zx")
        eps_p density mass (n,) body (n,) int32  id (n,) int64  [extra columns]
    /xdmf/polyvertex_N    int32 0 .. N-1: Polyvertex connectivity for the XDMF

Rows of a frame are body-major: all of body 0's particles (rank 0's, then rank 1's, ...),
then body 1's, and so on, so body ``b`` holds rows ``sum(body_counts[:b])`` onwards,
``body_counts[b]`` of them. The XDMF shows each body as a block named after it by
selecting its range (:mod:`pmpm.io.xdmf`), without a copy of the data. Within a body the
order depends on the ranks: sort by ``id`` to follow particles between frames. (Files
written before ``body_counts`` existed hold the ranks' rows one rank after another.)
"""
import os
import sys
from collections.abc import Mapping

import h5py
import numpy as np

from . import _collective as C
from ._files import atomic_write_text, dumps
from .xdmf import frame_text, topology_path, xdmf_document

STRESS_COMPONENTS = "xx,yy,zz,xy,yz,zx"
#: Columns every frame holds under the run contract, with their shape after the first axis.
CONTRACT_COLUMNS = {"x": (3,), "v": (3,), "stress": (6,), "eps_p": (), "density": (),
                    "mass": (), "body": (), "id": ()}


def _contract_problems(layout):
    """Contract columns missing from an agreed layout, or of the wrong shape."""
    shapes = {spec.name: spec.trailing for spec in layout.specs}
    missing = [name for name in CONTRACT_COLUMNS if name not in shapes]
    wrong = [f"{name} has rows of shape {shapes[name]}, expected {shape}"
             for name, shape in CONTRACT_COLUMNS.items() if name in shapes and shapes[name] != shape]
    return ([f"missing columns {missing}"] if missing else []) + wrong


def body_blocks(comm, body, n_names):
    """Rows of each body on each rank, an int64 array (ranks, bodies), the same on every
    rank (one allgather); at least ``n_names`` bodies wide.

    Raises
    ------
    ValueError
        On every rank alike, when a rank's ``body`` column holds a negative index.
    """
    body = np.asarray(body)
    negative = bool(body.size) and int(body.min()) < 0
    local = np.zeros(0, np.int64) if negative else np.bincount(body, minlength=n_names)
    gathered = comm.allgather((negative, local))
    bad = [rank for rank, (neg, _) in enumerate(gathered) if neg]
    if bad:
        raise ValueError(f"frame column 'body' holds negative body indices on ranks {bad}")
    width = max([n_names] + [len(counts) for _, counts in gathered])
    return np.array([np.pad(counts, (0, width - len(counts))) for _, counts in gathered],
                    dtype=np.int64)


def body_ranges(blocks, rank):
    """(first file row, row count) of each body's rows of ``rank``, in body order, for the
    body-major layout of :func:`body_blocks`' counts."""
    totals = blocks.sum(axis=0)
    body_start = np.concatenate([[0], np.cumsum(totals)[:-1]])
    return body_start + blocks[:rank].sum(axis=0), blocks[rank]


def by_body(columns, body):
    """``columns`` with their rows sorted by ``body`` (stable: the local order within a
    body is kept), each column sorted when it is read (:class:`BodyMajor`: a frame holds
    one sorted copy at a time)."""
    body = np.asarray(body)
    if body.size < 2 or bool(np.all(body[:-1] <= body[1:])):
        return BodyMajor(columns, None)
    return BodyMajor(columns, np.argsort(body, kind="stable"))


class BodyMajor(Mapping):
    """The columns (arrays, or pmpm.io.derived.Deferred) read in the row ``order`` (None:
    as they are), each as a fresh array when it is read."""

    def __init__(self, columns, order):
        self.columns, self.order = columns, order

    def __getitem__(self, name):
        value = np.asarray(self.columns[name])
        return value if self.order is None else value[self.order]

    def __iter__(self):
        return iter(self.columns)

    def __len__(self):
        return len(self.columns)


def _attr_value(value):
    """A value h5py stores as an attribute: numbers, strings, lists of them; else JSON."""
    if isinstance(value, (str, bool, int, float, np.generic, np.ndarray)):
        return value
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, str) for v in value):
        return list(value)
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, (int, float)) for v in value):
        return np.asarray(value)
    return dumps(value)


class ParticleWriter:
    """Writes particle frames collectively into one HDF5 file, and the XDMF after each frame.

    Every method is collective over ``comm``: all ranks call it, ranks with no particles
    included.

    Parameters
    ----------
    path : str or os.PathLike
        Output directory (the file is ``path/particles.h5``), or the ``.h5`` file itself.
        The XDMF goes beside it with the suffix ``.xdmf``.
    comm : mpi4py.MPI.Comm
        Communicator of the writing ranks (h5py's ``mpio`` driver needs the raw one).
    case_text : str
        The case file as given; stored as the ``/case`` dataset.
    attrs : dict
        Root attributes, notably ``body_names`` (list of str, index = ``body`` value).
        Strings, numbers and lists of them are stored as they are, anything else as JSON.
    restart_frame : int, optional
        Continue an existing file after a restart: frames ``0 .. restart_frame-1`` are kept,
        later ones (written after the checkpoint) are deleted, and the next frame written
        gets index ``restart_frame``. Default: start a new file.
    xdmf : bool, optional
        Rewrite the XDMF after every frame (default True).

    Notes
    -----
    ``case_text``, ``attrs``, frame times and run statistics are taken from rank 0 and
    broadcast, so the collective metadata writes are identical on every rank. The file
    stays open between frames and is flushed after each, so a crashed run leaves readable
    frames and an XDMF that lists exactly those.
    """

    def __init__(self, path, comm, case_text, attrs, *, restart_frame=None, xdmf=True):
        path = os.fspath(path)
        self.path = path if path.endswith(".h5") else os.path.join(path, "particles.h5")
        self.xdmf_path = os.path.splitext(self.path)[0] + ".xdmf"
        self.comm, self.xdmf = comm, xdmf
        self.body_names = []
        self._frames, self._texts = [], []
        os.makedirs(os.path.dirname(os.path.abspath(self.path)), exist_ok=True)
        if restart_frame is not None and not C.bcast_root(comm, os.path.exists(self.path)):
            if comm.rank == 0:
                sys.stderr.write(f"pmpm: warning: --restart: {self.path} is missing; the "
                                 f"frames from the checkpoint on go to a new file\n")
                sys.stderr.flush()
            restart_frame = None
        mode = "w" if restart_frame is None else "r+"
        self._file = h5py.File(self.path, mode, driver="mpio", comm=comm)
        self._write_header(*C.bcast_root(comm, (case_text, attrs)))
        if restart_frame is not None:
            self._truncate(int(restart_frame))

    @property
    def n_frames(self):
        """Number of frames in the file (the index the next frame gets)."""
        return len(self._frames)

    @property
    def h5_name(self):
        """The file's bare name, as the XDMF documents refer to it."""
        return os.path.basename(self.path)

    @property
    def frames(self):
        """Per-frame records ``{group, time, n, columns, topology, body_counts}`` as given
        to the XDMF (``body_counts`` None for a frame written rank after rank)."""
        return list(self._frames)

    def _write_header(self, case_text, attrs):
        f = self._file
        self.body_names = [str(name) for name in attrs.get("body_names", [])]
        for key, value in attrs.items():
            f.attrs[key] = _attr_value(value)
        f.attrs["ranks"] = self.comm.size
        f.attrs["software"] = "pmpm"
        f.attrs["frames"] = 0
        if "case" in f:
            del f["case"]
        raw = str(case_text).encode("utf-8")
        case = f.create_dataset("case", shape=(), dtype=h5py.string_dtype("utf-8", max(len(raw), 1)))
        C.write_root_only(case, np.bytes_(raw), self.comm.rank)
        f.require_group("frames")
        f.require_group("xdmf")

    def _truncate(self, keep):
        """Delete frames ``keep`` and later and rebuild the frame list from the file."""
        frames = self._file["frames"]
        names = sorted(frames, key=int)
        if keep > len(names):
            raise ValueError(f"restart_frame={keep} but {self.path} holds {len(names)} frames")
        for name in names[keep:]:
            del frames[name]
        self._frames = [self._record(frames[name]) for name in names[:keep]]
        self._texts = []
        self._file.attrs["frames"] = keep

    @staticmethod
    def _record(group):
        columns = {name: (d.dtype.str, int(np.prod(d.shape[1:], dtype=int)))
                   for name, d in group.items()}
        n = int(group.attrs["n"])
        counts = group.attrs.get("body_counts")
        return {"group": group.name, "time": float(group.attrs["time"]), "n": n,
                "step": int(group.attrs["step"]), "columns": columns,
                "topology": topology_path(n),
                "body_counts": None if counts is None else [int(c) for c in counts]}

    def write_frame(self, time, step, columns):
        """Write one frame of every rank's local particles (collective).

        Parameters
        ----------
        time : float
            Simulated time of the frame (rank 0's value is stored).
        step : int
            Step number of the frame.
        columns : dict of str to numpy.ndarray
            Local particle columns, first axis = particle: ``x`` (n,3), ``v`` (n,3),
            ``stress`` (n,6, Voigt xx,yy,zz,xy,yz,zx), ``eps_p``, ``density``, ``mass`` (n,),
            ``body`` (n,) int32, ``id`` (n,) int64, and any extra 1D or 2D columns. All
            ranks pass the same names; ranks with n = 0 pass empty arrays. Rows are
            stored body-major (module notes), whatever their order here.

        Returns
        -------
        int
            Index of the frame written.

        Raises
        ------
        ValueError
            On every rank alike, before anything is written, when a contract column is
            missing or misshapen, the ranks disagree on the columns, or a body index is
            negative.
        """
        layout = C.agree_layout(self.comm, columns)
        problems = _contract_problems(layout)
        if problems:
            raise ValueError("frame columns: " + "; ".join(problems))
        blocks = body_blocks(self.comm, columns["body"], len(self.body_names))
        columns = by_body(columns, columns["body"])
        time, step = C.bcast_root(self.comm, (float(time), int(step)))
        index = len(self._frames)
        group = self._file["frames"].create_group(f"{index:06d}", track_order=True)
        group.attrs.update({"time": time, "step": step, "n": layout.total,
                            "body_counts": blocks.sum(axis=0)})
        datasets = C.create_columns(group, layout)
        if "stress" in datasets:
            datasets["stress"].attrs["components"] = STRESS_COMPONENTS
        self._write_rows(datasets, layout, blocks, columns)
        self._require_topology(layout)
        self._file.attrs["frames"] = index + 1
        self._file.flush()
        self._frames.append(self._record(group))
        self._write_xdmf()
        return index

    def _write_rows(self, datasets, layout, blocks, columns):
        """Every column's rows of this rank into its bodies' ranges: one collective write
        per column (``columns`` sorted by body)."""
        if layout.total == 0:
            return
        starts, counts = body_ranges(blocks, self.comm.rank)
        dxpl = C.collective_xfer()
        for spec in layout.specs:
            C.write_row_ranges(datasets[spec.name], starts, counts, columns[spec.name], dxpl)

    def _require_topology(self, layout):
        """Write ``/xdmf/polyvertex_N`` (indices 0 .. N-1) once per distinct count N."""
        path = topology_path(layout.total)
        if layout.total == 0 or path in self._file:
            return
        dtype = np.int32 if layout.total < 2**31 else np.int64
        dset = self._file.create_dataset(path, shape=(layout.total,), dtype=dtype, fill_time="never")
        start, count = layout.offset(self.comm.rank), layout.counts[self.comm.rank]
        C.write_rows(dset, start, np.arange(start, start + count, dtype=dtype), C.collective_xfer())

    def _write_xdmf(self):
        """Rewrite the XDMF (rank 0), building the elements of the frames not yet in it."""
        if not (self.xdmf and self.comm.rank == 0):
            return
        self._texts += [frame_text(self.h5_name, frame, self.body_names)
                        for frame in self._frames[len(self._texts):]]
        atomic_write_text(self.xdmf_path, xdmf_document(self._texts))

    def close(self, run_stats=None):
        """Store the run statistics and close the file (collective; safe to call twice).

        Parameters
        ----------
        run_stats : dict, optional
            JSON-able statistics (wall time, steps, particle-steps per second, ...), taken
            from rank 0 and stored as the root attribute ``run_stats`` (a JSON string).
        """
        if self._file is None:
            return
        stats = C.bcast_root(self.comm, run_stats)
        if stats is not None:
            self._file.attrs["run_stats"] = dumps(stats, allow_nan=True)
        self._file.close()
        self._file = None
