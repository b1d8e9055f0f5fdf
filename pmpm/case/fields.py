"""Declarative readers for case mappings: each key's type, default, unit, one line of
documentation and range checks.

A reader is a callable ``read(value, path, problems) -> value``; it returns the cleaned
value, or ``INVALID`` after adding a problem. Readers are small objects that also say
what they accept (``kind()``, the type column of the reference) and hold their nested
field tables (``Nested.fields``, ``ListOf.item``, ``Tagged.variants``), so the reference
(``pmpm.case.reference``) is generated from the very tables that validate. ``read_mapping``
applies a table of ``Field``s to a mapping, reports unknown keys (with "did you mean") and
missing required keys, and fills defaults. ``INVALID`` values are passed through silently:
their problem is already listed.
"""
import copy
import math
import dataclasses
from dataclasses import dataclass
from typing import Any, Callable, ClassVar

from .errors import describe, did_you_mean, join, unknown_name
from .expressions import check_field


class Marker:
    """A named sentinel value; the reference shows its name."""

    def __init__(self, name):
        self.name = name

    def __repr__(self):
        return self.name

    def __deepcopy__(self, memo):
        return self


INVALID = Marker("INVALID")     # a value whose problem has been reported
REQUIRED = Marker("REQUIRED")   # Field default: the key must be given
OMIT = Marker("OMIT")           # Field default: leave the key out when not given


@dataclass(frozen=True)
class Field:
    """One key of a mapping: how it is read, its default (a value, ``REQUIRED`` or
    ``OMIT``), its unit in the case's consistent system ("mm", "ms", "MPa", "1" for a
    pure number, "" for what is not a physical quantity) and one line of documentation."""
    read: Callable
    default: Any = REQUIRED
    unit: str = ""
    doc: str = ""


def read_mapping(raw, path, fields, problems):
    """Validated dict for ``raw`` per ``fields`` (key -> Field); INVALID if not a mapping."""
    if not is_mapping(raw, path, problems, f"a mapping with keys {', '.join(fields)}"):
        return INVALID
    report_unknown_keys(raw, fields, path, problems)
    out = {}
    for key, field in fields.items():
        value = _read_field(raw.get(key), join(path, key), field, problems)
        if value is not OMIT:
            out[key] = value
    return out


def is_mapping(raw, path, problems, expected):
    """True if ``raw`` is a dict; else reports "expected EXPECTED; got ..." (nothing for
    an INVALID value, whose problem is already listed)."""
    if raw is INVALID:
        return False
    if not isinstance(raw, dict):
        problems.add(path, f"expected {expected}; got {describe(raw)}")
        return False
    return True


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

@dataclass(frozen=True, eq=False)
class Bound:
    """A range check: ``holds(x)`` must be true; ``text`` states the range (``"> 0"``)."""
    holds: Callable
    text: str

    def __call__(self, x):
        return None if self.holds(x) else f"must be {self.text}, got {x:g}"


def greater(bound):
    return Bound(lambda x: x > bound, f"> {bound:g}")


def at_least(bound):
    return Bound(lambda x: x >= bound, f">= {bound:g}")


def at_most(bound):
    return Bound(lambda x: x <= bound, f"<= {bound:g}")


def between(low, high):
    """Open interval (low, high)."""
    return Bound(lambda x: low < x < high, f"in ({low:g}, {high:g})")


def _check(value, checks, path, problems):
    for check in checks:
        message = check(value)
        if message:
            problems.add(path, message)
            return INVALID
    return value


def _ranged(kind, checks):
    """``"number > 0, <= 1"``: a kind with the ranges of its checks."""
    return " ".join([kind, ", ".join(check.text for check in checks)]).strip()


# readers: read(value, path, problems) -> value; kind() -> the reference's type column

@dataclass(frozen=True, eq=False)
class Number:
    """A finite float satisfying every check."""
    checks: tuple = ()
    name = "number"
    expected = "a finite number"

    def __call__(self, value, path, problems):
        x = as_number(value)
        if x is None or not self.accepts(x):
            problems.add(path, f"expected {self.expected}, got {describe(value)}")
            return INVALID
        return _check(self.convert(x), self.checks, path, problems)

    @staticmethod
    def accepts(x):
        return math.isfinite(x)

    @staticmethod
    def convert(x):
        return float(x)

    def kind(self):
        return _ranged(self.name, self.checks)


@dataclass(frozen=True, eq=False)
class Integer(Number):
    """An int (an integral float is accepted) satisfying every check."""
    name = "int"
    expected = "a whole number"

    @staticmethod
    def accepts(x):
        return math.isfinite(x) and float(x) == int(x)

    @staticmethod
    def convert(x):
        return int(x)


@dataclass(frozen=True, eq=False)
class FieldNumber:
    """A finite number, or a string expression of the position x, y, z that is evaluated
    at every particle when the body is filled (an initial field)."""

    def __call__(self, value, path, problems):
        if isinstance(value, str):
            problem = check_field(value)
            if problem:
                problems.add(path, problem)
                return INVALID
            return value.strip()
        return Number()(value, path, problems)

    def kind(self):
        return "number or expression of x, y, z"


@dataclass(frozen=True, eq=False)
class FieldVector:
    """Three items, each a :class:`FieldNumber`."""

    def __call__(self, value, path, problems):
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            problems.add(path, f"expected a list of 3 numbers or expressions of x, y, z, "
                         f"got {describe(value)}")
            return INVALID
        items = [FieldNumber()(v, join(path, i), problems) if v is not INVALID else INVALID
                 for i, v in enumerate(value)]
        return INVALID if INVALID in items else items

    def kind(self):
        return "vector of numbers or expressions of x, y, z"


@dataclass(frozen=True, eq=False)
class Vector:
    """A list of ``length`` finite floats (each item reported by its own path)."""
    length: int = 3
    nonzero: bool = False

    def __call__(self, value, path, problems):
        if not isinstance(value, (list, tuple)) or len(value) != self.length:
            problems.add(path, f"expected a list of {self.length} numbers, "
                         f"got {describe(value)}")
            return INVALID
        items = [Number()(v, join(path, i), problems) if v is not INVALID else INVALID
                 for i, v in enumerate(value)]
        if INVALID in items:
            return INVALID
        if self.nonzero and not any(items):
            problems.add(path, "must not be the zero vector")
            return INVALID
        return items

    def kind(self):
        return "vector, not zero" if self.nonzero else "vector"


@dataclass(frozen=True, eq=False)
class NumberList:
    """A list of at least ``min_length`` finite floats (``min_length`` 0: may be empty)."""
    min_length: int = 1

    def __call__(self, value, path, problems):
        if not isinstance(value, (list, tuple)) or len(value) < self.min_length:
            problems.add(path, f"expected a list of at least {self.min_length} numbers, "
                         f"got {describe(value)}")
            return INVALID
        return Vector(len(value))(value, path, problems)

    def kind(self):
        least = f" (at least {self.min_length})" if self.min_length > 1 else ""
        return "list of numbers" + least


@dataclass(frozen=True, eq=False)
class Choice:
    """One of ``options`` (strings); ``aliases`` maps accepted synonyms to an option."""
    options: Any
    what: str = "value"
    aliases: dict = dataclasses.field(default_factory=dict)

    def __call__(self, value, path, problems):
        if isinstance(value, str) and value in self.aliases:
            return self.aliases[value]
        if not isinstance(value, str) or value not in self.options:
            problems.add(path, unknown_name(self.what, value,
                                            list(self.options) + list(self.aliases)))
            return INVALID
        return value

    def kind(self):
        return ", ".join(f"`{option}`" for option in self.options)


@dataclass(frozen=True, eq=False)
class Boolean:
    def __call__(self, value, path, problems):
        if not isinstance(value, bool):
            problems.add(path, f"expected true or false, got {describe(value)}")
            return INVALID
        return value

    def kind(self):
        return "bool"


@dataclass(frozen=True, eq=False)
class BooleanOrAuto:
    """true, false, or ``auto``: pmpm decides from the rest of the case."""

    def __call__(self, value, path, problems):
        if not isinstance(value, bool) and value != "auto":
            problems.add(path, f"expected true, false or auto, got {describe(value)}")
            return INVALID
        return value

    def kind(self):
        return "bool or `auto`"


@dataclass(frozen=True, eq=False)
class Text:
    def __call__(self, value, path, problems):
        if isinstance(value, bool) or not isinstance(value, (str, int, float)):
            problems.add(path, f"expected a string, got {describe(value)}")
            return INVALID
        return str(value)

    def kind(self):
        return "string"


@dataclass(frozen=True, eq=False)
class Nested:
    """A nested mapping read with its own field table."""
    fields: dict

    def __call__(self, value, path, problems):
        return read_mapping(value, path, self.fields, problems)

    def kind(self):
        return "mapping"


@dataclass(frozen=True, eq=False)
class Tagged:
    """A mapping whose ``type`` key picks its field table from ``variants`` (type name ->
    fields); the keys of ``common`` are accepted with every type. ``docs`` says in one
    line what each type is."""
    variants: dict
    what: str
    common: dict = dataclasses.field(default_factory=dict)
    docs: dict = dataclasses.field(default_factory=dict)
    tag: ClassVar[str] = "type"

    def __call__(self, raw, path, problems):
        tag = self.tag
        if not is_mapping(raw, path, problems,
                          f"a mapping with a '{tag}' ({', '.join(self.variants)})"):
            return INVALID
        kind = _read_field(raw.get(tag), join(path, tag), self.type_field(), problems)
        if kind is INVALID:
            return INVALID
        return read_mapping(raw, path, self.fields_of(kind), problems)

    def type_field(self):
        return Field(Choice(self.variants, self.what), doc=f"the {self.what}")

    def fields_of(self, kind):
        """The whole field table of a mapping of type ``kind``."""
        return {self.tag: self.type_field(), **self.variants[kind], **self.common}

    def variant_doc(self, kind):
        return self.docs.get(kind, "")

    def kind(self):
        return f"mapping with `{self.tag}`"


@dataclass(frozen=True, eq=False)
class TaggedByModel(Tagged):
    """A :class:`Tagged` mapping whose ``model`` key (not ``type``) picks the variant,
    as a material's does (e.g. a material's ``damage`` block)."""
    tag: ClassVar[str] = "model"


@dataclass(frozen=True, eq=False)
class ListOf:
    """A list whose items are read by ``item`` at paths ``path[i]``."""
    item: Callable
    min_length: int = 0
    what: str = "item"

    def __call__(self, value, path, problems):
        if not isinstance(value, list) or len(value) < self.min_length:
            what = self.what if self.min_length == 1 else f"{self.what}s"
            problems.add(path, f"expected a list of at least {self.min_length} {what}, "
                         f"got {describe(value)}")
            return INVALID
        return [self.item(item, join(path, i), problems) for i, item in enumerate(value)]

    def kind(self):
        return f"list (at least {self.min_length})" if self.min_length else "list"


@dataclass(frozen=True, eq=False)
class NamedItems:
    """A non-empty mapping of name -> item, each item (a ``what``) read by ``item`` at
    ``path.name``; ``expected`` is the problem reported for anything else."""
    item: Callable
    what: str
    expected: str

    def __call__(self, value, path, problems):
        if not isinstance(value, dict) or not value:
            problems.add(path, self.expected)
            return INVALID
        return {str(name): self.item(item, join(path, str(name)), problems)
                for name, item in value.items()}

    def kind(self):
        return f"mapping name: {self.what}"


@dataclass(frozen=True, eq=False)
class Checked:
    """``inner``, then ``check(value, path, problems)``: the checks that involve several
    keys. ``check`` returns the value (possibly completed) and must accept ``INVALID``."""
    inner: Callable
    check: Callable

    def __call__(self, value, path, problems):
        return self.check(self.inner(value, path, problems), path, problems)

    def kind(self):
        return self.inner.kind()


@dataclass(frozen=True, eq=False)
class Custom:
    """A reader function with no field table of its own; ``text`` says what it accepts."""
    read: Callable
    text: str

    def __call__(self, value, path, problems):
        return self.read(value, path, problems)

    def kind(self):
        return self.text


def number(*checks):
    return Number(checks)


def integer(*checks):
    return Integer(checks)


def vector(length=3, nonzero=False):
    return Vector(length, nonzero)


def number_list(min_length=1):
    return NumberList(min_length)


def choice(options, what="value", aliases=None):
    return Choice(options, what, aliases or {})


def boolean():
    return Boolean()


def boolean_or_auto():
    return BooleanOrAuto()


def text():
    return Text()


def mapping(fields):
    return Nested(fields)


def list_of(read_item, min_length=0, what="item"):
    return ListOf(read_item, min_length, what)


def unwrap(reader):
    """The reader under any ``Checked`` layers (the one that holds the field table)."""
    while isinstance(reader, Checked):
        reader = reader.inner
    return reader


def defaults_of(fields):
    """The mapping a section takes when it is left out (every field must have a default)."""
    return {key: field.default for key, field in fields.items() if field.default is not OMIT}


def valid(mapping, *keys):
    """True if ``mapping`` is a dict whose ``keys`` are all present and not INVALID."""
    return (isinstance(mapping, dict)
            and all(key in mapping and not has_invalid(mapping[key]) for key in keys))
