"""Declarative readers for case mappings: each key's type, default and range checks.

A reader is ``read(value, path, problems) -> value``; it returns the cleaned value, or
``INVALID`` after adding a problem. ``read_mapping`` applies a table of ``Field``s to a
mapping, reports unknown keys (with "did you mean") and missing required keys, and fills
defaults. ``INVALID`` values are passed through silently: their problem is already listed.
"""
import copy
import math
from dataclasses import dataclass
from typing import Any, Callable

from .errors import describe, did_you_mean, join, unknown_name


class _Marker:
    def __init__(self, name):
        self.name = name

    def __repr__(self):
        return self.name

    def __deepcopy__(self, memo):
        return self


INVALID = _Marker("INVALID")      # a value whose problem has been reported
REQUIRED = _Marker("REQUIRED")    # Field default: the key must be given
OMIT = _Marker("OMIT")            # Field default: leave the key out when not given


@dataclass(frozen=True)
class Field:
    read: Callable
    default: Any = REQUIRED


def read_mapping(raw, path, fields, problems):
    """Validated dict for ``raw`` per ``fields`` (key -> Field); INVALID if not a mapping."""
    if raw is INVALID:
        return INVALID
    if not isinstance(raw, dict):
        problems.add(path, f"expected a mapping with keys {', '.join(fields)}; "
                     f"got {describe(raw)}")
        return INVALID
    report_unknown_keys(raw, fields, path, problems)
    out = {}
    for key, field in fields.items():
        value = _read_field(raw.get(key), join(path, key), field, problems)
        if value is not OMIT:
            out[key] = value
    return out


def report_unknown_keys(raw, allowed, path, problems):
    for key in raw:
        if key not in allowed:
            hint = did_you_mean(key, allowed) or f" (allowed: {', '.join(allowed)})"
            problems.add(join(path, key), f"unknown key{hint}")


def _read_field(value, path, field, problems):
    if value is None:
        if field.default is REQUIRED:
            problems.add(path, "missing (required)")
            return INVALID
        return copy.deepcopy(field.default)
    if value is INVALID:
        return INVALID
    return field.read(value, path, problems)


def has_invalid(*values):
    """True if any value, or any item of a dict/list value, is INVALID."""
    for value in values:
        if value is INVALID:
            return True
        if isinstance(value, dict) and has_invalid(*value.values()):
            return True
        if isinstance(value, list) and has_invalid(*value):
            return True
    return False


def as_number(value):
    """``value`` as int/float, or None (bools are not numbers; numeric strings are)."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return value
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return None
    return None


# checks: value -> message or None

def greater(bound):
    return lambda x: None if x > bound else f"must be > {bound:g}, got {x:g}"


def at_least(bound):
    return lambda x: None if x >= bound else f"must be >= {bound:g}, got {x:g}"


def at_most(bound):
    return lambda x: None if x <= bound else f"must be <= {bound:g}, got {x:g}"


def between(low, high):
    """Open interval (low, high)."""
    return lambda x: None if low < x < high else f"must be in ({low:g}, {high:g}), got {x:g}"


def _check(value, checks, path, problems):
    for check in checks:
        message = check(value)
        if message:
            problems.add(path, message)
            return INVALID
    return value


# readers

def number(*checks):
    """A finite float satisfying every check."""
    def read(value, path, problems):
        x = as_number(value)
        if x is None or not math.isfinite(x):
            problems.add(path, f"expected a finite number, got {describe(value)}")
            return INVALID
        return _check(float(x), checks, path, problems)
    return read


def integer(*checks):
    """An int (an integral float is accepted) satisfying every check."""
    def read(value, path, problems):
        x = as_number(value)
        if x is None or not math.isfinite(x) or float(x) != int(x):
            problems.add(path, f"expected a whole number, got {describe(value)}")
            return INVALID
        return _check(int(x), checks, path, problems)
    return read


def vector(length=3, nonzero=False):
    """A list of ``length`` finite floats (each item reported by its own path)."""
    def read(value, path, problems):
        if not isinstance(value, (list, tuple)) or len(value) != length:
            problems.add(path, f"expected a list of {length} numbers, got {describe(value)}")
            return INVALID
        items = [number()(v, join(path, i), problems) if v is not INVALID else INVALID
                 for i, v in enumerate(value)]
        if INVALID in items:
            return INVALID
        if nonzero and not any(items):
            problems.add(path, "must not be the zero vector")
            return INVALID
        return items
    return read


def number_list(min_length=1):
    """A list of at least ``min_length`` finite floats (``min_length`` 0: may be empty)."""
    def read(value, path, problems):
        if not isinstance(value, (list, tuple)) or len(value) < min_length:
            problems.add(path, f"expected a list of at least {min_length} numbers, "
                         f"got {describe(value)}")
            return INVALID
        return vector(len(value))(value, path, problems)
    return read


def choice(options, what="value", aliases=None):
    """One of ``options`` (strings); ``aliases`` maps accepted synonyms to an option."""
    aliases = aliases or {}
    def read(value, path, problems):
        if isinstance(value, str) and value in aliases:
            return aliases[value]
        if not isinstance(value, str) or value not in options:
            problems.add(path, unknown_name(what, value, list(options) + list(aliases)))
            return INVALID
        return value
    return read


def boolean():
    def read(value, path, problems):
        if not isinstance(value, bool):
            problems.add(path, f"expected true or false, got {describe(value)}")
            return INVALID
        return value
    return read


def text():
    def read(value, path, problems):
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            problems.add(path, f"expected a string, got {describe(value)}")
            return INVALID
        return str(value)
    return read


def mapping(fields):
    """A nested mapping read with its own field table."""
    return lambda value, path, problems: read_mapping(value, path, fields, problems)


def read_tagged(raw, path, variants, problems, what, common=None):
    """A mapping whose ``type`` key picks its field table from ``variants``."""
    if raw is INVALID:
        return INVALID
    if not isinstance(raw, dict):
        problems.add(path, f"expected a mapping with a 'type' ({', '.join(variants)}); "
                     f"got {describe(raw)}")
        return INVALID
    kind = _read_field(raw.get("type"), join(path, "type"),
                       Field(choice(variants, what)), problems)
    if kind is INVALID:
        return INVALID
    fields = {"type": Field(choice(variants, what)), **variants[kind], **(common or {})}
    return read_mapping(raw, path, fields, problems)


def list_of(read_item, min_length=0, what="item"):
    """A list whose items are read by ``read_item`` at paths ``path[i]``."""
    def read(value, path, problems):
        if not isinstance(value, list) or len(value) < min_length:
            problems.add(path, f"expected a list of at least {min_length} {what}s, "
                         f"got {describe(value)}")
            return INVALID
        return [read_item(item, join(path, i), problems) for i, item in enumerate(value)]
    return read


def defaults_of(fields):
    """The mapping a section takes when it is left out (every field must have a default)."""
    return {key: field.default for key, field in fields.items() if field.default is not OMIT}


def valid(mapping, *keys):
    """True if ``mapping`` is a dict whose ``keys`` are all present and not INVALID."""
    return (isinstance(mapping, dict)
            and all(key in mapping and not has_invalid(mapping[key]) for key in keys))
