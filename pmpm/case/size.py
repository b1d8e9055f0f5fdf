"""The memory a case needs, estimated before any body is filled (issue 17).

A body's particle count is its shape's volume times (particles_per_cell / cell)^3, with
the share of the volume cut off by symmetry faces or lying inside refined windows taken
from a coarse sample of the shape (about ``SAMPLES`` lattice points, rotation applied):
``--set params.cell=0.01`` on the Taylor bar (1e10 particles) is then refused in a
fraction of a second instead of filling until memory runs out. The grid counts the nodes
of the particles' bounding box and of each window. The bytes are set against this
machine's available memory (MemAvailable, for all the ranks on it together) or
``decomposition.memory_limit_gb``."""
import math
import os

import numpy as np

from .errors import join
from .fill import clip_at_symmetry_planes, in_window, rotate_points, windows_of
from .mesh import MeshReadError, lattice_points_in_tets, read_tets
from .points import PointReadError, read_points
from .shapes import CSG, make_shape, nose_length, reference_point
from .surface import (SurfaceError, lattice_points_in_surface, read_surface,
                      surface_volume)

#: Lattice points sampled per body for the shares of its volume (cut, refined).
SAMPLES = 200_000
#: Peak resident bytes a run adds per particle (docs/performance-notes.md: 433-469 on
#: the Taylor bar, 370-377 on the 1 M block; the particle store itself is 252).
PARTICLE_BYTES = 480
#: Bytes per grid node (the steel ball on a thin plate: about 750 MB for 2.7 M nodes
#: beyond its particles, docs/performance-notes.md "Large thin plates").
NODE_BYTES = 300
#: Bytes per particle while every rank fills every body to check it (positions, volumes
#: and the masks and copies of the fill).
FILL_BYTES = 64
#: Environment variables giving the number of MPI ranks on this machine.
LOCAL_RANKS_VARIABLES = ("OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS", "PMI_LOCAL_SIZE")
#: An FEM element with its share of the nodes, counted as particles of the same memory
#: (about 1 kB: the element's columns, its 8 node indices, its nodes' columns, and the
#: whole mesh every rank holds at the set-up).
ELEMENT_PARTICLES = 2.0


def shape_volume(geometry, tets=None):
    """Exact volume of an analytic geometry (or of the mesh's tetrahedra ``tets``); None
    for a union or difference (body_estimate counts its sample)."""
    kind = geometry["type"]
    if kind in CSG:
        return None
    if kind == "box":
        return float(np.prod(np.subtract(geometry["max"], geometry["min"])))
    if kind == "cylinder":
        inner = geometry.get("inner_radius", 0.0)
        return math.pi * (geometry["radius"] ** 2 - inner ** 2) * geometry["length"]
    if kind == "sphere":
        return 4.0 / 3.0 * math.pi * geometry["radius"] ** 3
    if kind == "ogive":
        diameter, crh = geometry["diameter"], geometry["crh"]
        radius, rho = diameter / 2, crh * diameter
        nose = nose_length(diameter, crh)
        t = np.linspace(0.0, nose, 4001)
        y = np.clip(np.sqrt(np.clip(rho ** 2 - t ** 2, 0, None)) - (rho - radius), 0, None)
        area = math.pi * y ** 2
        nose_volume = float(np.sum((area[1:] + area[:-1]) / 2) * (t[1] - t[0])) if nose else 0.0
        return math.pi * radius ** 2 * (geometry["length"] - nose) + nose_volume
    if kind == "prism":
        corners = np.asarray(geometry["section"], float)[np.asarray(geometry["blocks"])]
        x, y = corners[..., 0], corners[..., 1]
        area = 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y)
        return float(area) * geometry["length"]
    edges = tets[:, 1:] - tets[:, :1]
    return float(np.abs(np.linalg.det(edges)).sum() / 6.0)


def _sample(geometry, tets, surface=None):
    """Lattice points (global frame, rotation applied) inside the geometry (or the mesh's
    tetrahedra ``tets``, or the closed ``surface`` (points, triangles)), about SAMPLES of
    them, and the volume each stands for."""
    if tets is not None:
        lo, hi = tets.reshape(-1, 3).min(axis=0), tets.reshape(-1, 3).max(axis=0)
    elif surface is not None:
        lo, hi = surface[0].min(axis=0), surface[0].max(axis=0)
    else:
        shape = make_shape(geometry)
        lo, hi = (np.asarray(b, float) for b in shape.bounds())
    extent = np.maximum(hi - lo, 1e-300)
    spacing = float(np.prod(extent) / SAMPLES) ** (1 / 3)
    spacing = max(spacing, float(extent.max()) / 2000)      # no more than 2000 per axis
    counts = np.minimum(np.maximum(np.floor(extent / spacing), 1), 4000).astype(int)
    each = spacing ** 3
    if tets is not None:
        points = lattice_points_in_tets(tets, lo, spacing)
    elif surface is not None:
        points = lattice_points_in_surface(*surface, lo, spacing)
    else:
        each = float(np.prod(extent / counts))
        axes = [lo[a] + (np.arange(counts[a]) + 0.5) * extent[a] / counts[a]
                for a in range(3)]
        mesh = np.meshgrid(*axes, indexing="ij")
        points = np.stack([m.ravel() for m in mesh], axis=1)
        points = points[shape.contains(points)]
    if geometry.get("rotate"):
        points = rotate_points(points, geometry["rotate"])
    return points, each


def fem_estimate(body, grid, case_dir):
    """(the elements of an FEM body counted as particles of the same memory, lower and
    upper corners of its nodes or None): an FEM body is its elements, not a volume
    filled with particles (issue 27: a 400-element plate was estimated at 8e7
    particles)."""
    from .fem import FEM_GEOMETRIES, MAX_ELEMENTS, element_count
    from .hexmesh import read_hexes
    from .fields import has_invalid
    geometry = body["geometry"]
    fem = body.get("fem") if isinstance(body.get("fem"), dict) else {}
    size = fem.get("element_size", grid["cell"])
    if has_invalid(fem) or not isinstance(size, (int, float)) or \
            geometry["type"] not in FEM_GEOMETRIES:
        return 0.0, None                     # refused naming the key
    count = element_count(geometry, size)
    if count is not None and not count <= MAX_ELEMENTS:
        return 0.0, None                     # refused naming fem.element_size
    if count is None:
        try:
            points, hexes = read_hexes(os.path.join(case_dir, geometry["file"]),
                                       geometry["scale"], geometry["translate"])
        except (MeshReadError, ValueError):
            return 0.0, None                 # reported when the FEM bodies are checked
        return len(hexes) * ELEMENT_PARTICLES, (points.min(axis=0), points.max(axis=0))
    lo, hi = (np.asarray(b, float) for b in make_shape(geometry).bounds())
    corners = np.array([[(lo, hi)[k >> a & 1][a] for a in range(3)] for k in range(8)])
    if geometry.get("rotate"):
        corners = rotate_points(corners, geometry["rotate"])
    return count * ELEMENT_PARTICLES, (corners.min(axis=0), corners.max(axis=0))


def body_estimate(body, grid, case_dir):
    """(estimated particles, lower and upper corners of them or None) of a valid body
    (an FEM body's elements counted as particles: fem_estimate)."""
    if body.get("method") == "fem":
        return fem_estimate(body, grid, case_dir)
    geometry, ppc = body["geometry"], body["particles_per_cell"]
    if geometry["type"] == "points":
        return points_estimate(geometry, case_dir)
    tets = surface = None
    try:
        if geometry["type"] == "mesh":
            tets = read_tets(os.path.join(case_dir, geometry["file"]), geometry["scale"],
                             geometry["translate"])
        elif geometry["type"] == "surface":
            surface = read_surface(os.path.join(case_dir, geometry["file"]),
                                   geometry["scale"], geometry["translate"])
    except (MeshReadError, SurfaceError):
        return 0.0, None                     # reported when the bodies are filled
    points, each = _sample(geometry, tets, surface)
    volume = surface_volume(*surface) if surface is not None else \
        shape_volume(geometry, tets)
    if volume is None:                       # a union or difference: its sample's
        volume = len(points) * each
    density = (ppc / grid["cell"]) ** 3
    if len(points) == 0:                     # smaller than the sample's spacing
        return volume * density, None
    kept = clip_at_symmetry_planes(points, grid)
    if len(kept) == 0:
        return 0.0, None
    weights = np.full(len(kept), density)
    for window in windows_of(grid):
        weights[in_window(kept, window, grid)] = density * window["ratio"] ** 3
    estimate = volume * float(weights.sum()) / len(points)
    return estimate, (kept.min(axis=0), kept.max(axis=0))


def points_estimate(geometry, case_dir):
    """(the particles of a point file, their bounding box): read, not estimated."""
    try:
        points, _ = read_points(geometry, case_dir)
    except PointReadError:
        return 0.0, None                     # reported when the bodies are filled
    if geometry.get("rotate"):
        points = rotate_points(points, geometry["rotate"])
    return float(len(points)), (points.min(axis=0), points.max(axis=0))


def grid_nodes(grid, boxes):
    """Nodes of the coarse grid over the particles' bounding box (with a layer of halo
    nodes each side) and of every window."""
    if not boxes:
        return 0.0
    lo = np.maximum(np.min([b[0] for b in boxes], axis=0), grid["min"])
    hi = np.minimum(np.max([b[1] for b in boxes], axis=0), grid["max"])
    nodes = float(np.prod(np.maximum(hi - lo, 0) / grid["cell"] + 3))
    for window in windows_of(grid):
        extent = np.subtract(window["max"], window["min"]) * window["ratio"] / grid["cell"]
        nodes += float(np.prod(extent + 3))
    return nodes


def local_ranks():
    """MPI ranks on this machine (from the launcher's environment; 1 without one)."""
    for name in LOCAL_RANKS_VARIABLES:
        try:
            return max(int(os.environ[name]), 1)
        except (KeyError, ValueError):
            continue
    return 1


def available_bytes():
    """MemAvailable of /proc/meminfo in bytes, or None where unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def needed_bytes(particles, nodes, ranks):
    """Peak bytes of a run of ``particles`` and ``nodes`` on ``ranks`` ranks: the run,
    or the check that fills every body on every rank, whichever is larger."""
    return max(particles * PARTICLE_BYTES + nodes * NODE_BYTES,
               particles * FILL_BYTES * ranks)


def _bytes(n):
    if not math.isfinite(n):
        return "more than 1e308 bytes"
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def _count(x):
    if not math.isfinite(x):
        return "more than 1e308"
    return f"{x:,.0f}" if x < 1e7 else f"{x:.2g}"


def _about(x, show=_count):
    return ("about " if math.isfinite(x) else "") + show(x)


def _int(n):
    return str(n) if n < 1e9 else f"{float(n):.3g}"


def case_estimate(bodies, grid, case_dir="."):
    """(particles per body index, grid nodes) estimated for ``bodies``, a mapping of
    the valid bodies' indices to them."""
    counts, boxes = {}, []
    with np.errstate(all="ignore"):
        for i, body in bodies.items():
            try:
                count, box = body_estimate(body, grid, case_dir)
            except OverflowError:           # sizes near 1e308: beyond any memory
                count, box = math.inf, None
            counts[i] = count if math.isfinite(count) else math.inf
            if box is not None:
                boxes.append(box)
        try:
            nodes = grid_nodes(grid, boxes)
        except OverflowError:
            nodes = math.inf
    return counts, nodes


#: the geometries whose volume :func:`shape_volume` gives exactly, without a file
ANALYTIC = ("box", "cylinder", "sphere", "ogive", "prism")


def upper_bound(bodies, grid):
    """(particles, grid nodes) no fewer than :func:`case_estimate` gives, without its
    samples (some 0.05 s a body, every start; issue 25): each particle body's exact
    volume (a union's or difference's bounding box) at the density of the finest
    window, the nodes over the bodies' bounding boxes. None where a body's file would
    have to be read (mesh, surface and point files, meshed FEM bodies) or the bound is
    not finite. FEM bodies count as :func:`fem_estimate` counts them."""
    finest = max([1] + [window["ratio"] for window in windows_of(grid)])
    total, boxes = 0.0, []
    try:
        with np.errstate(all="ignore"):
            for body in bodies.values():
                geometry = body["geometry"]
                if geometry["type"] not in ANALYTIC + CSG:
                    return None
                if body.get("method") == "fem":
                    count, box = fem_estimate(body, grid, ".")
                else:
                    count, box = _shape_bound(geometry, body["particles_per_cell"] *
                                              finest / grid["cell"])
                total += count
                if box is not None:
                    boxes.append(box)
            nodes = grid_nodes(grid, boxes)
    except OverflowError:
        return None
    return (total, nodes) if math.isfinite(total) and math.isfinite(nodes) else None


def _shape_bound(geometry, per_length):
    """(the particles of an analytic geometry at ``per_length`` particles per unit
    length or more, the box around its turned bounding box)."""
    lo, hi = (np.asarray(b, float) for b in make_shape(geometry).bounds())
    volume = shape_volume(geometry) if geometry["type"] in ANALYTIC else \
        float(np.prod(hi - lo))
    corners = np.array([[(lo, hi)[k >> a & 1][a] for a in range(3)] for k in range(8)])
    if geometry.get("rotate"):
        corners = rotate_points(corners, geometry["rotate"])
    return volume * per_length ** 3, (corners.min(axis=0), corners.max(axis=0))


def check_memory(bodies, grid, limit_gb, case_dir, problems, ranks=None, available=None):
    """Add one problem, naming the keys that set the size, when the case's estimated
    memory exceeds ``limit_gb`` (decomposition.memory_limit_gb) or else this machine's
    available memory. Returns True when the case fits (the bodies may then be filled)."""
    ranks = local_ranks() if ranks is None else ranks
    if limit_gb is not None:
        limit, source = limit_gb * 1e9, f"decomposition.memory_limit_gb = {limit_gb:g}"
    else:
        limit = available_bytes() if available is None else available
        source = f"the {_bytes(limit or 0)} this machine has available"
    if limit is None:
        return True
    bound = upper_bound(bodies, grid)
    if bound is not None and needed_bytes(*bound, ranks) <= limit:
        return True                 # surely fits: no sample (issue 25, start-up)
    counts, nodes = case_estimate(bodies, grid, case_dir)
    particles = float(sum(counts.values()))
    needed = needed_bytes(particles, nodes, ranks)
    if needed <= limit:
        return True
    largest = max(counts, key=counts.get)
    ppc = bodies[largest]["particles_per_cell"]
    ppc_key = join(join("bodies", largest), "particles_per_cell")
    key = ppc_key if ppc > 4 else "grid.cell"
    ratios = [f"grid.windows[{k}].ratio = {_int(w['ratio'])}" for k, w in
              enumerate(windows_of(grid)) if w["ratio"] > 1]
    body_text = ", ".join(f"bodies[{i}] '{bodies[i]['name']}' {_count(c)}"
                          for i, c in counts.items() if c >= 0.01 * particles)
    problems.add(key, f"the case needs {_about(particles)} particles ({body_text}) and "
                 f"{_count(nodes)} grid nodes at grid.cell = {grid['cell']:g}, "
                 f"{ppc_key} = {_int(ppc)}" + "".join(", " + r for r in ratios)
                 + f": {_about(needed, _bytes)} of memory on {ranks} rank"
                 + ("" if ranks == 1 else "s") + f", more than {source}; make grid.cell "
                 f"larger or particles_per_cell smaller, or set "
                 f"decomposition.memory_limit_gb (GB) to allow more")
    return False
