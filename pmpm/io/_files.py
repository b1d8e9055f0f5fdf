"""Small file helpers shared by the output writers: atomic text writes, JSON conversion."""
import json
import math
import os

import numpy as np


def resolve(path, default_name):
    """Return ``path`` itself, or ``path/default_name`` when ``path`` is a directory.

    Parameters
    ----------
    path : str or os.PathLike
        A file path, or an existing output directory.
    default_name : str
        File name used inside a directory, e.g. ``"summary.json"``.
    """
    path = os.fspath(path)
    return os.path.join(path, default_name) if os.path.isdir(path) else path


def fsync_path(path):
    """Flush a file (or directory) that is already closed to stable storage."""
    flags = os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) if os.path.isdir(path) else os.O_RDONLY
    fd = os.open(path, flags)
    try:
        os.fsync(fd)
    except OSError:  # some file systems refuse fsync on directories
        pass
    finally:
        os.close(fd)


def atomic_write_text(path, text):
    """Write ``text`` to ``path`` so that readers see the old file or the new one, never half.

    Notes
    -----
    The text goes to ``path.tmp.PID`` in the same directory, is flushed and fsynced, and
    then replaces ``path`` with :func:`os.replace`, which is atomic on POSIX.
    """
    path = os.fspath(path)
    tmp = f"{path}.tmp.{os.getpid()}"
    try:
        with open(tmp, "w", encoding="utf-8") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def jsonable(value):
    """Convert numpy scalars and arrays (nested in dicts, lists, tuples) to plain Python.

    Raises
    ------
    TypeError
        If a value has no JSON form (sets, objects, ...).
    """
    if isinstance(value, dict):
        return {str(key): jsonable(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(item) for item in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise TypeError(f"{type(value).__name__} value {value!r} has no JSON form")


def dumps(value, allow_nan=False, **kwargs):
    """``json.dumps`` after :func:`jsonable`; NaN and infinity are refused unless allowed.

    With ``allow_nan=True`` they are written as ``NaN``/``Infinity``, which Python's json
    reads back exactly but strict JSON parsers refuse: use it for files only pmpm reads.
    """
    return json.dumps(jsonable(value), allow_nan=allow_nan, **kwargs)


def nonfinite_paths(value, where=""):
    """Dotted key paths of the NaN or infinite floats nested in ``value``."""
    if isinstance(value, dict):
        return [p for key, item in value.items() for p in nonfinite_paths(item, f"{where}.{key}")]
    if isinstance(value, (list, tuple, np.ndarray)):
        return [p for k, item in enumerate(value) for p in nonfinite_paths(item, f"{where}[{k}]")]
    if isinstance(value, (float, np.floating)) and not math.isfinite(value):
        return [where.lstrip(".")]
    return []


def is_finite_number(value):
    """True for a real, finite int or float (bool excluded)."""
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    return math.isfinite(value)
