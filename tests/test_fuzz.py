"""A seeded fuzz test of the case files (issue 17): the shipped cases (runs/*.yaml and
tests/cases/*.yaml) mutated in their values' types (number to string, list, mapping, null),
to extreme values (0, -1, 1e308, nan, inf), with keys deleted or unknown keys added, lists
and mappings swapped, and in their raw bytes (flipped, truncated). pmpm must either accept
a mutant or refuse it with lines that each name a key or the file ("pmpm: error: KEY:
..."), never a traceback, a hang or a crash. The bulk is validated in-process
(``load_checked_case``, which fills the bodies); a sample runs the command line for a
few steps, serially and on 2 ranks. Every mutant is drawn from numpy's generator with a
fixed seed, so a failure names a reproducible mutant."""
import glob
import math
import os
import time

import numpy as np
import pytest
import yaml

from clihelp import ROOT, pmpm, pmpm_lines
from pmpm.app import InputError, load_checked_case

CASES = sorted(glob.glob(os.path.join(ROOT, "runs", "*.yaml"))
               + glob.glob(os.path.join(ROOT, "tests", "cases", "*.yaml")))
#: Cases small enough to run a few steps on the command line in about a second.
SMALL = [p for p in CASES if os.path.basename(p) in (
    "cli_bar.yaml", "two_blocks.yaml", "sliding_block.yaml", "planar_shock.yaml",
    "initial_fields.yaml", "window_follow.yaml", "vibrating_bar.yaml", "rings.yaml")]
HOSTILE = [None, "x", "", [1, 2], {"a": 1}, 0, -1, 1e308, -1e308, math.nan, math.inf,
           -math.inf, True, 10 ** 30]
#: A few steps of any of the cases (extra frame times beyond the end are dropped).
SHORT = ["time.end=2e-6", "output.times=[]"]


def paths(tree, prefix=()):
    """Every (path, value) of a YAML tree, the root excluded."""
    items = tree.items() if isinstance(tree, dict) else (
        enumerate(tree) if isinstance(tree, list) else ())
    for key, value in items:
        yield prefix + (key,), value
        yield from paths(value, prefix + (key,))


def parent_of(tree, path):
    for key in path[:-1]:
        tree = tree[key]
    return tree


def mutate_tree(tree, rng):
    """A copy of ``tree`` with one structural or value mutation, and its description."""
    import copy
    tree = copy.deepcopy(tree)
    found = list(paths(tree))
    path, value = found[rng.integers(len(found))]
    parent, key = parent_of(tree, path), path[-1]
    kind = rng.choice(["value", "value", "value", "delete", "unknown", "swap"])
    where = ".".join(map(str, path))
    if kind == "value":
        new = HOSTILE[rng.integers(len(HOSTILE))]
        parent[key] = new
        return tree, f"{where} = {new!r}"
    if kind == "delete":
        del parent[key]
        return tree, f"delete {where}"
    if kind == "unknown":
        target = value if isinstance(value, dict) else parent
        if isinstance(target, dict):
            target["zz_unknown"] = 1
            return tree, f"unknown key in {where}"
        parent[key] = {"zz_unknown": value}
        return tree, f"{where} wrapped in a mapping"
    if isinstance(value, list):
        parent[key] = {str(i): v for i, v in enumerate(value)}
        return tree, f"{where}: list to mapping"
    if isinstance(value, dict):
        parent[key] = list(value.values())
        return tree, f"{where}: mapping to list"
    parent[key] = [value]
    return tree, f"{where}: scalar to list"


def mutate_bytes(data, rng):
    """``data`` with a few bytes replaced, or cut short."""
    if rng.random() < 0.3:
        cut = int(rng.integers(len(data)))
        return data[:cut], f"truncated at byte {cut}"
    data = bytearray(data)
    where = rng.integers(len(data), size=int(rng.integers(1, 4)))
    for i in where:
        data[i] = int(rng.integers(256))
    return bytes(data), f"bytes {sorted(map(int, where))} replaced"


def mutant(seed, tmp_path, cases=CASES):
    """(path of a mutated case file beside its original's meshes, description)."""
    rng = np.random.default_rng(seed)
    source = cases[rng.integers(len(cases))]
    with open(source, "rb") as f:
        data = f.read()
    if rng.random() < 0.25:
        data, what = mutate_bytes(data, rng)
    else:
        tree, what = mutate_tree(yaml.safe_load(data), rng)
        data = yaml.safe_dump(tree, sort_keys=False).encode()
    path = os.path.join(tmp_path, f"fuzz_{seed}.yaml")
    with open(path, "wb") as f:
        f.write(data)
    return path, f"seed {seed}: {os.path.relpath(source, ROOT)}: {what}"


def names_a_key(line):
    """'key: message' (a key path, or the file name with line and column)."""
    head, sep, rest = line.partition(": ")
    return bool(sep and head and rest)


@pytest.mark.parametrize("seed", range(40))
def test_a_mutant_is_accepted_or_refused_naming_a_key(tmp_path, seed):
    path, what = mutant(seed, tmp_path)
    start = time.monotonic()
    try:
        load_checked_case(path, SHORT)
    except InputError as error:
        assert error.problems, what
        bad = [line for line in error.problems if not names_a_key(line)]
        assert not bad, (what, bad)
    assert time.monotonic() - start < 10, what


def check_cli(done, what):
    assert done.returncode in (0, 1, 2), (what, done.returncode, done.stderr[-3000:])
    assert "Traceback" not in done.stderr, (what, done.stderr[-3000:])
    lines = pmpm_lines(done.stderr)
    if done.returncode == 2:
        errors = [line.removeprefix("pmpm: error: ") for line in lines
                  if line.startswith("pmpm: error: ")]
        assert errors and all(names_a_key(e) for e in errors), (what, lines)
    if done.returncode == 1:        # a fault the run reports, never an internal error
        assert any(line.startswith("pmpm: run stopped: ") for line in lines), (what, lines)


@pytest.mark.parametrize("ranks, seeds", [(1, range(106, 111)), (2, range(204, 209))])
def test_mutants_on_the_command_line(tmp_path, ranks, seeds):
    ran = []
    for seed in seeds:
        path, what = mutant(seed, tmp_path, SMALL)
        sets = [x for s in SHORT for x in ("--set", s)]
        done = pmpm([path, "--out", tmp_path / f"out{seed}", "--quiet", *sets], ranks,
                    timeout=60)
        check_cli(done, what)
        ran.append(done.returncode == 0)
    assert any(ran), "no mutant ran: the sample tests refusals only"


@pytest.mark.parametrize("setting, start", [
    # each a traceback before: the bodies were filled with an invalid boundary, the
    # cell count of the box overflowed, the memory estimate overflowed
    ("grid.boundary=0", "grid.boundary: expected a mapping"),
    ("grid.max=[1e308, 9.12, 26.6]", "grid.max: the grid box holds 1.32e+308 x 24 x 35 cells"),
    ("grid.cell=1e-300", "grid.max: the grid box holds"),
    ("bodies[0].particles_per_cell=1e308",
     "bodies[0].particles_per_cell: the case needs more than 1e308 particles"),
    ("grid.windows[0].ratio=1e308", "grid.cell: the case needs more than 1e308 particles"),
    ("bodies[0].geometry.radius=1e308", "grid.cell: the case needs more than 1e308"),
    # the output schedule listed 1e9 frame times before the run: a hang
    ("output.frames=1000000000", "output.frames: 1e+09 frames: at most 1,000,000"),
])
def test_hostile_values_found_by_the_fuzzer_are_refused(setting, start):
    with pytest.raises(InputError) as error:
        load_checked_case(os.path.join(ROOT, "runs", "taylor_bar.yaml"), [setting])
    assert any(line.startswith(start) for line in error.value.problems), \
        error.value.problems


# -- FEM bodies and the meshes they read (issue 27) --------------------------------------
FEM_CASES = [p for p in CASES if "method: fem" in open(p, encoding="utf-8").read()]
#: a case of an FEM body read from MESH and a particle block meeting it by surface contact
MESH_CASE = {
    "grid": {"min": [-2, -2, -2], "max": [5, 4, 5], "cell": 1.0},
    "materials": {"steel": {"model": "elastic", "density": 7.8e-3, "E": 2e5, "nu": 0.3}},
    "bodies": [{"name": "part", "material": "steel", "method": "fem",
                "geometry": {"type": "mesh", "file": "MESH"}},
               {"name": "block", "material": "steel",
                "geometry": {"type": "box", "min": [0, 0, 2.5], "max": [2, 2, 3.5]},
                "velocity": [0, 0, -10]}],
    "contact": {"coupling": "surface"},
    "time": {"end": 0.001},
    "output": {"frames": 1}}
MESH_FORMATS = ("vtu", "msh", "inp")
BAD_COORDINATES = (math.nan, math.inf, -math.inf, 1e308, -1e308, 1e6)


@pytest.mark.parametrize("seed", range(20))
def test_an_fem_case_mutant_is_accepted_or_refused_naming_a_key(tmp_path, seed):
    path, what = mutant(1000 + seed, tmp_path, FEM_CASES)
    try:
        load_checked_case(path, SHORT)
    except InputError as error:
        bad = [line for line in error.problems if not names_a_key(line)]
        assert error.problems and not bad, (what, bad)


def mesh_mutant(seed, directory):
    """(case file reading a mutated 3 x 2 x 2 box mesh, description): node coordinates,
    connectivity or cell blocks changed, written as VTU, Gmsh or Abaqus."""
    from pmpm.case.hexmesh import box_mesh
    rng = np.random.default_rng(seed)
    points, hexes = box_mesh([0, 0, 0], [3, 2, 2], [3, 2, 2])
    cells = [("hexahedron", hexes.copy())]
    kind = rng.choice(["coordinate", "connectivity", "blocks"])
    node, element = int(rng.integers(len(points))), int(rng.integers(len(hexes)))
    if kind == "coordinate":
        other = int(rng.integers(len(points)))
        if rng.random() < 0.3:
            points[node] = points[other]
            what = f"node {node} moved onto node {other}"
        else:
            value = BAD_COORDINATES[rng.integers(len(BAD_COORDINATES))]
            points[node, rng.integers(3)] = value
            what = f"node {node} coordinate {value!r}"
    elif kind == "connectivity":
        choice = rng.integers(5)
        corner = int(rng.integers(8))
        if choice == 0:
            index = int(rng.choice([-1, -len(points), len(points), len(points) + 7]))
            hexes[element, corner] = index
            what = f"hexahedron {element} corner {corner} = {index}"
        elif choice == 1:
            other = int(rng.integers(len(points)))
            hexes[element, corner] = other
            what = f"hexahedron {element} corner {corner} = node {other}"
        elif choice == 2:
            hexes[element, [0, 1]] = hexes[element, [1, 0]]
            what = f"hexahedron {element}: two corners swapped"
        elif choice == 3:
            hexes = np.concatenate([hexes, hexes[element:element + 1]])
            what = f"hexahedron {element} repeated"
        else:
            hexes = hexes[:0]
            what = "no hexahedra"
        cells = [("hexahedron", hexes)]
    else:
        choice = rng.integers(3)
        if choice == 0:
            cells = [("hexahedron", np.zeros((0, 8), np.int64)), ("hexahedron", hexes)]
            what = "an empty block first"
        elif choice == 1:
            cells = [("hexahedron", hexes[:element]), ("hexahedron", hexes[element:])]
            what = f"hexahedra in two blocks at {element}"
        else:
            cells = [("hexahedron", hexes), ("tetra", hexes[:1, :4])]
            what = "a tetrahedron beside the hexahedra"
    suffix = MESH_FORMATS[rng.integers(len(MESH_FORMATS))]
    mesh = os.path.join(directory, f"mesh_{seed}.{suffix}")
    import meshio
    try:
        meshio.write(mesh, meshio.Mesh(points, cells))
    except Exception:                      # a writer that cannot hold the mutant
        suffix = "msh"
        mesh = os.path.join(directory, f"mesh_{seed}.msh")
        meshio.write(mesh, meshio.Mesh(points, cells), file_format="gmsh22", binary=False)
    text = yaml.safe_dump(MESH_CASE, sort_keys=False).replace("MESH", os.path.basename(mesh))
    path = os.path.join(directory, f"mesh_case_{seed}.yaml")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path, f"seed {seed}: {kind}: {what} ({suffix})"


@pytest.mark.parametrize("seed", range(40))
def test_a_mesh_mutant_is_accepted_or_refused_naming_a_key(tmp_path, seed):
    """Never a traceback: before issue 27 an index past the nodes raised IndexError, an
    Abaqus file's empty block too, and a negative index passed as the last node."""
    path, what = mesh_mutant(seed, tmp_path)
    try:
        load_checked_case(path, SHORT)
    except InputError as error:
        bad = [line for line in error.problems if not names_a_key(line)]
        assert error.problems and not bad, (what, bad)
        assert all(line.startswith(("bodies[0]", "bodies[1].geometry", "contact"))
                   for line in error.problems), (what, error.problems)
        return
    assert "corner" not in what or "= node" in what or "swapped" in what, (
        f"{what}: a node index past the mesh was accepted")
    assert "repeated" not in what and "coordinate" not in what and "onto" not in what, (
        f"{what}: accepted")


@pytest.mark.parametrize("ranks, seeds", [(1, (5, 6)), (2, (7, 8))])
def test_mesh_mutants_on_the_command_line(tmp_path, ranks, seeds):
    for seed in seeds:
        path, what = mesh_mutant(seed, tmp_path)
        sets = [x for s in SHORT for x in ("--set", s)]
        done = pmpm([path, "--out", tmp_path / f"out{seed}", "--quiet", *sets], ranks,
                    timeout=120)
        check_cli(done, what)
