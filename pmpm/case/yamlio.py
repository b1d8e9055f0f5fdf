"""Reading case YAML: plain safe loading, plus two fixes that matter for numeric input.

PyYAML follows YAML 1.1, where ``117e3`` and ``1.0e-4`` are strings (a float needs a dot
and a signed exponent). The case loader reads any decimal literal with an exponent as a
float. It also reports duplicate keys, which PyYAML would otherwise silently overwrite.

Hostile input is refused with one line: aliases that would expand a document to more
than ``ALIAS_LIMIT`` extra nodes (an "alias bomb"), NUL bytes and bytes that are not UTF-8.
"""
import re

import yaml

from .errors import CaseError

_FLOAT_WITH_EXPONENT = re.compile(r"""^(?:
     [-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+
    |[-+]?\.[0-9][0-9_]*[eE][-+]?[0-9]+)$""", re.X)


class CaseLoader(yaml.SafeLoader):
    """SafeLoader with exponent floats and duplicate-key reports in ``self.duplicates``."""

    def __init__(self, stream):
        super().__init__(stream)
        self.duplicates = []

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            key = key_node.value if isinstance(key_node, yaml.ScalarNode) else None
            if key is not None and key in seen:
                self.duplicates.append(
                    f"line {key_node.start_mark.line + 1}: duplicate key {key!r}")
            seen.add(key)
        return super().construct_mapping(node, deep=deep)


CaseLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_WITH_EXPONENT,
                                 list("-+0123456789."))

ALIAS_LIMIT = 100_000  # nodes that aliases may add to a document when expanded


def _expanded_size(node, sizes):
    """Nodes in ``node`` with every alias expanded; ``sizes`` memoizes by node id.
    A node that contains itself counts as infinitely large."""
    key = id(node)
    if key in sizes:
        return sizes[key]
    sizes[key] = float("inf")  # until finished: a cycle back here is unbounded
    sizes[key] = 1 + sum(_expanded_size(child, sizes) for child in _children(node))
    return sizes[key]


def _children(node):
    if isinstance(node, yaml.SequenceNode):
        return node.value
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def _check_aliases(node, source):
    """CaseError when aliases would expand ``node`` by more than ALIAS_LIMIT nodes."""
    sizes = {}
    if node is not None and _expanded_size(node, sizes) - len(sizes) > ALIAS_LIMIT:
        raise CaseError([f"{source}: YAML aliases expand beyond the limit of "
                         f"{ALIAS_LIMIT} nodes; refusing to load"])


def parse_yaml(text, source):
    """Parse YAML ``text``; return (data, problems). Syntax errors, NUL bytes and alias
    bombs raise CaseError."""
    _refuse_nul(text, source)
    try:
        return _load(text, source)
    except yaml.YAMLError as error:
        raise CaseError([f"{source}: YAML syntax error: {_one_line(error)}"]) from None


def _load(text, source):
    loader = CaseLoader(text)  # raises ReaderError on control characters
    try:
        node = loader.get_single_node()
        _check_aliases(node, source)
        data = loader.construct_document(node) if node is not None else None
    finally:
        loader.dispose()
    return data, [f"{source} {d}" for d in loader.duplicates]


def read_yaml_file(path):
    """Read a case file; return (data, problems about duplicate keys)."""
    try:
        with open(path, "rb") as stream:
            data = stream.read()
    except OSError as error:
        reason = error.strerror or error
        raise CaseError([f"{path}: cannot read case file: {reason}"]) from None
    return parse_yaml(_decode(data, str(path)), str(path))


def _decode(data, source):
    """``data`` as UTF-8 text, or CaseError naming the line and column of a bad byte."""
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        where = _position(data, error.start, b"\n")
        bad = data[error.start]
        raise CaseError([f"{source}:{where}: not UTF-8 text (byte 0x{bad:02x})"]) from None


def _refuse_nul(text, source):
    """CaseError naming the line and column of the first NUL in ``text``, if any."""
    index = text.find("\0")
    if index >= 0:
        where = _position(text, index, "\n")
        raise CaseError([f"{source}:{where}: NUL byte"])


def _position(text, index, newline):
    """``LINE:COLUMN`` (both from 1) of ``index`` in ``text`` (str or bytes)."""
    line_start = text.rfind(newline, 0, index) + 1
    return f"{text.count(newline, 0, index) + 1}:{index - line_start + 1}"


def parse_value(text):
    """Parse a ``--set`` value as YAML (``0.38`` -> float, ``[0, 0, -190]`` -> list)."""
    data, _ = parse_yaml(text, "value")
    return data


def _one_line(error):
    return " ".join(str(error).split())
