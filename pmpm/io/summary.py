"""Run summary (``DIR/summary.json``) with the keys of the run contract, written atomically.

The solver computes the values; this module checks that every contract key is there with
a value of the right kind, converts numpy types, and writes the file so that a reader never
sees it half-written. Keys beyond the contract are kept as they are.
"""
import json

import numpy as np

from ._files import atomic_write_text, dumps, is_finite_number, nonfinite_paths, resolve

#: Top-level keys and their kind: "int", "number", or a nested schema dict.
SCHEMA = {
    "ranks": "int",
    "n_particles": {"initial": "int", "final": "int"},
    "n_steps": "int",
    "t_end": "number",
    "wall_s": "number",
    "compile_s": "number",
    "particle_steps_per_s": "number",
    "energy": {"kinetic": "number", "internal": "number", "total": "number"},
}
#: Keys of each ``bodies.NAME`` entry.
BODY_SCHEMA = {
    "mass": "number", "n_particles": "int", "centroid": "vector",
    "velocity": "vector", "bbox_min": "vector", "bbox_max": "vector",
}


def _check_value(kind, value, where):
    """Problems with one value (a list of strings, empty when it is fine)."""
    if kind == "int":
        ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool)
        return [] if ok else [f"{where}: expected an integer, got {value!r}"]
    if kind == "number":
        return [] if is_finite_number(value) else [f"{where}: expected a finite number, got {value!r}"]
    if kind == "vector":
        ok = hasattr(value, "__len__") and len(value) == 3 and all(map(is_finite_number, value))
        return [] if ok else [f"{where}: expected 3 finite numbers, got {value!r}"]
    return _check_dict(kind, value, where)


def _check_dict(schema, data, where):
    if not isinstance(data, dict):
        return [f"{where}: expected a mapping, got {data!r}"]
    problems = []
    for key, kind in schema.items():
        path = f"{where}.{key}" if where else key
        if key not in data:
            problems.append(f"{path}: missing")
        else:
            problems += _check_value(kind, data[key], path)
    return problems


def validate_summary(summary):
    """All problems with a summary dict, one string per problem naming its key path.

    Returns
    -------
    list of str
        Empty when the summary holds every contract key with a value of the right kind.
    """
    problems = _check_dict(SCHEMA, summary, "")
    bodies = summary.get("bodies") if isinstance(summary, dict) else None
    if not isinstance(bodies, dict) or not bodies:
        return problems + [f"bodies: expected a non-empty mapping of name to values, got {bodies!r}"]
    for name, body in bodies.items():
        problems += _check_dict(BODY_SCHEMA, body, f"bodies.{name}")
    reported = {problem.split(":")[0] for problem in problems}
    extra = [p for p in nonfinite_paths(summary) if p.split("[")[0] not in reported]
    return problems + [f"{path}: NaN or infinity has no JSON form" for path in extra]


def write_summary(path, summary):
    """Check ``summary`` against the run contract and write it as JSON, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file, or an output directory (then ``path/summary.json``).
    summary : dict
        ``ranks``, ``n_particles`` {``initial``, ``final``}, ``n_steps``, ``t_end``,
        ``wall_s``, ``compile_s``, ``particle_steps_per_s``, ``energy`` {``kinetic``,
        ``internal``, ``total``}, ``bodies`` {NAME: {``mass``, ``n_particles``,
        ``centroid``, ``velocity``, ``bbox_min``, ``bbox_max``}}; more keys are allowed.
        numpy scalars and arrays are converted.

    Returns
    -------
    str
        The path written.

    Raises
    ------
    ValueError
        Listing every missing or malformed key, one per line; nothing is written.
    """
    problems = validate_summary(summary)
    if problems:
        raise ValueError("summary does not follow the run contract:\n" + "\n".join(problems))
    path = resolve(path, "summary.json")
    atomic_write_text(path, dumps(summary, indent=2) + "\n")
    return path


def read_summary(path):
    """Load a summary written by :func:`write_summary` (a file or its directory)."""
    with open(resolve(path, "summary.json"), encoding="utf-8") as handle:
        return json.load(handle)
