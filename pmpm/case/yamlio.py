"""Reading case YAML: plain safe loading, plus two fixes that matter for numeric input.

PyYAML follows YAML 1.1, where ``117e3`` and ``1.0e-4`` are strings (a float needs a dot
and a signed exponent). The case loader reads any decimal literal with an exponent as a
float. It also reports duplicate keys, which PyYAML would otherwise silently overwrite.

Hostile input is refused with one line: aliases that would expand a document to more
than ``ALIAS_LIMIT`` extra nodes (an "alias bomb"), collections nested more than
``DEPTH_LIMIT`` deep, in the text or through aliases (PyYAML composes recursively, so 10000
nested ``[`` raised RecursionError), NUL bytes and bytes that are not UTF-8.
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
DEPTH_LIMIT = 100      # nested collections; a case file needs about 6


def _measure(root):
    """(nodes, depth, distinct nodes) of ``root`` with every alias expanded, without
    recursion; a node that contains itself gives infinite nodes and depth."""
    size, depth, on_path = {}, {}, set()
    stack = [(root, False)]
    while stack:
        node, finished = stack.pop()
        key = id(node)
        if finished:
            children = _children(node)
            size[key] = 1 + sum(size[id(c)] for c in children)
            depth[key] = 1 + max((depth[id(c)] for c in children), default=0)
            on_path.discard(key)
            continue
        if key in size:
            continue
        on_path.add(key)
        stack.append((node, True))
        for child in _children(node):
            if id(child) in on_path:
                return float("inf"), float("inf"), len(size)
            if id(child) not in size:
                stack.append((child, False))
    return size[id(root)], depth[id(root)], len(size)


def _children(node):
    if isinstance(node, yaml.SequenceNode):
        return node.value
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def _check_aliases(node, source):
    """CaseError when aliases would expand ``node`` by more than ALIAS_LIMIT nodes, or
    nest it more than DEPTH_LIMIT deep."""
    if node is None:
        return
    size, depth, distinct = _measure(node)
    if size - distinct > ALIAS_LIMIT:
        raise CaseError([f"{source}: YAML aliases expand beyond the limit of "
                         f"{ALIAS_LIMIT} nodes; refusing to load"])
    if depth > DEPTH_LIMIT + 1:          # + 1: scalars count as a level here
        raise CaseError([f"{source}: YAML aliases nest collections more than "
                         f"{DEPTH_LIMIT} deep; refusing to load"])


def _check_nesting(text, source):
    """CaseError naming the line and column where the text nests collections more than
    DEPTH_LIMIT deep, before PyYAML composes it (recursively)."""
    depth = 0
    for event in yaml.parse(text, Loader=yaml.SafeLoader):
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > DEPTH_LIMIT:
                mark = event.start_mark
                raise CaseError([f"{source}:{mark.line + 1}:{mark.column + 1}: YAML "
                                 f"collections nested more than {DEPTH_LIMIT} deep; "
                                 f"refusing to load"])
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1


def parse_yaml(text, source):
    """Parse YAML ``text``; return (data, problems). Syntax errors, NUL bytes and alias
    bombs raise CaseError."""
    _refuse_nul(text, source)
    try:
        return _load(text, source)
    except yaml.YAMLError as error:
        raise CaseError([f"{source}: YAML syntax error: {_one_line(error)}"]) from None


def _load(text, source):
    _check_nesting(text, source)
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
