"""The case schema: the top-level sections, their keys and defaults, and the checks that
relate one section to another. ``validate_case`` runs the whole pipeline on a raw tree.
"""
import copy
import math

from .contact import check_contact, read_contact
from .windows import check_window_bodies, check_windows, read_window
from .bodies import check_bodies_in_grid, check_mesh_files, check_min_below_max, read_body
from .errors import CaseError, Problems, join, unknown_name
from .fields import (INVALID, Field, at_least, at_most, boolean, choice, defaults_of,
                     greater, integer, list_of, mapping, number, number_list,
                     read_mapping, read_tagged, text, valid, vector)
from .materials import read_materials
from .overrides import apply_overrides
from .params import resolve_params, substitute

FACES = ("x-", "x+", "y-", "y+", "z-", "z+")
BOUNDARY = {face: Field(choice(("fixed", "slip", "free", "symmetry"), "boundary condition"),
                        "free") for face in FACES}
GRID = {"min": Field(vector()), "max": Field(vector()), "cell": Field(number(greater(0))),
        "boundary": Field(mapping(BOUNDARY), defaults_of(BOUNDARY)),
        "windows": Field(list_of(read_window, 0, "window"), [])}
TIME = {"end": Field(number(greater(0))), "cfl": Field(number(greater(0), at_most(1)), 0.5),
        "dt_max": Field(number(greater(0)), None),
        "scheme": Field(choice(("usf", "musl"), "update scheme"), "usf")}
OUTPUT = {"frames": Field(integer(at_least(1)), 10),
          "history_every": Field(integer(at_least(1)), 10),
          "checkpoint_every": Field(integer(at_least(0)), 0),
          "progress": Field(boolean(), True),
          "times": Field(number_list(0), [])}
DECOMPOSITION = {"axis": Field(choice(("auto", "x", "y", "z"), "axis"), "auto"),
                 "rebalance_threshold": Field(number(greater(0)), 0.2),
                 "check_every": Field(integer(at_least(1)), 50)}
TIME_FUNCTIONS = {"constant": {}, "ramp": {"t_rise": Field(number(greater(0)))},
                  "table": {"t": Field(number_list(2)), "f": Field(number_list(2))}}
REGION = {"min": Field(vector()), "max": Field(vector())}


def read_load(raw, path, problems):
    fields = {"name": Field(text()), "body": Field(text()),
              "type": Field(choice(("traction", "force"), "load type")),
              "region": Field(mapping(REGION)), "value": Field(vector()),
              "time_function": Field(read_time_function, {"type": "constant"})}
    load = read_mapping(raw, path, fields, problems)
    if valid(load, "region"):
        check_min_below_max(load["region"], join(path, "region"), problems)
    return load


def read_time_function(raw, path, problems):
    function = read_tagged(raw, path, TIME_FUNCTIONS, problems, "time function")
    if not valid(function, "t", "f"):
        return function
    t, f = function["t"], function["f"]
    if len(t) != len(f):
        problems.add(path, f"t and f must have the same length (got {len(t)} and {len(f)})")
    elif any(b <= a for a, b in zip(t, t[1:])):
        problems.add(join(path, "t"), "times must increase strictly")
    return function


def read_grid(raw, path, problems):
    grid = read_mapping(raw, path, GRID, problems)
    if check_min_below_max(grid, path, problems) and valid(grid, "cell"):
        grid["max"] = rounded_max(grid["min"], grid["max"], grid["cell"])
        check_windows(grid, path, problems)
    return grid


def rounded_max(low, high, cell):
    """``high`` moved up so that ``high - low`` is a whole number of cells (the result is
    tidied to 12 significant digits: the solver takes round((max - min) / cell) cells)."""
    cells = [math.ceil((b - a) / cell - 1e-9) for a, b in zip(low, high)]
    return [float(f"{a + n * cell:.12g}") for a, n in zip(low, cells)]


def _read_materials(raw, path, problems):
    return read_materials(raw, problems)


def top_level_fields(default_title):
    return {
        "title": Field(text(), default_title),
        "params": Field(lambda value, path, problems: value, {}),
        "grid": Field(read_grid),
        "gravity": Field(vector(), [0.0, 0.0, 0.0]),
        "materials": Field(_read_materials),
        "bodies": Field(list_of(read_body, 1, "body")),
        "loads": Field(list_of(read_load, 0, "load"), []),
        "time": Field(mapping(TIME)),
        "output": Field(mapping(OUTPUT), defaults_of(OUTPUT)),
        "decomposition": Field(mapping(DECOMPOSITION), defaults_of(DECOMPOSITION)),
        "contact": Field(read_contact, {"method": 0, "friction": 0.0, "skip_separating": False,
                                        "normal": "average", "pairs": []}),
    }


def validate_case(raw, case_dir=".", default_title="case", overrides=(),
                  check_geometry=True, problems=None):
    """Validated case dict from the raw YAML tree ``raw`` (see ``load_case``)."""
    problems = problems if problems is not None else Problems()
    if not isinstance(raw, dict):
        raise CaseError(list(problems.lines) + ["(case): expected a mapping of sections "
                                                "(grid, materials, bodies, time, ...)"])
    tree = copy.deepcopy(raw)
    apply_overrides(tree, overrides, problems)
    params = resolve_params(tree.get("params"), problems)
    tree = {k: (v if k == "params" else substitute(v, params, problems, k))
            for k, v in tree.items()}
    case = read_mapping(tree, "", top_level_fields(default_title), problems)
    case["params"] = params
    check_references(case, problems)
    bodies = [] if case["bodies"] is INVALID else case["bodies"]
    if check_geometry and valid(case["grid"], "min", "max", "cell", "windows"):
        check_bodies_in_grid(bodies, case["grid"], case_dir, problems)
    else:
        check_mesh_files(bodies, case_dir, problems)
    problems.raise_if_any()
    return case


def check_references(case, problems):
    """Names are unique and every name referred to exists."""
    bodies = [] if case["bodies"] is INVALID else case["bodies"]
    loads = [] if case["loads"] is INVALID else case["loads"]
    materials = case["materials"]
    body_names = _unique_names(bodies, "bodies", problems)
    _unique_names(loads, "loads", problems)
    for i, body in enumerate(bodies):
        if materials is not INVALID and valid(body, "material") \
                and body["material"] not in materials:
            problems.add(join(join("bodies", i), "material"),
                         unknown_name("material", body["material"], materials))
    _check_output_times(case, problems)
    if all(valid(body, "name") for body in bodies):
        check_contact(case["contact"], body_names, problems)
        check_window_bodies(case["grid"], body_names, problems)
    names_complete = all(valid(body, "name") for body in bodies)
    for i, load in enumerate(loads):
        if valid(load, "body") and names_complete and load["body"] not in body_names:
            problems.add(join(join("loads", i), "body"),
                         unknown_name("body", load["body"], body_names))


def _check_output_times(case, problems):
    if not (valid(case["output"], "times") and valid(case["time"], "end")):
        return
    end = case["time"]["end"]
    for i, t in enumerate(case["output"]["times"]):
        if not 0 < t <= end:
            problems.add(f"output.times[{i}]", f"must be in (0, time.end = {end:g}], got {t:g}")


def _unique_names(items, section, problems):
    first = {}
    for i, item in enumerate(items):
        if not valid(item, "name"):
            continue
        name = item["name"]
        if name in first:
            problems.add(join(join(section, i), "name"),
                         f"duplicate name {name!r} (also {section}[{first[name]}])")
        first.setdefault(name, i)
    return first
