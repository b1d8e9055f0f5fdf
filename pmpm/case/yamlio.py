"""Reading case YAML: plain safe loading, plus two fixes that matter for numeric input.

PyYAML follows YAML 1.1, where ``117e3`` and ``1.0e-4`` are strings (a float needs a dot
and a signed exponent). The case loader reads any decimal literal with an exponent as a
float. It also reports duplicate keys, which PyYAML would otherwise silently overwrite.
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


def parse_yaml(text, source):
    """Parse YAML ``text``; return (data, problems). Syntax errors raise CaseError."""
    loader = CaseLoader(text)
    try:
        data = loader.get_single_data()
    except yaml.YAMLError as error:
        raise CaseError([f"{source}: YAML syntax error: {_one_line(error)}"]) from None
    finally:
        loader.dispose()
    return data, [f"{source} {d}" for d in loader.duplicates]


def read_yaml_file(path):
    """Read a case file; return (data, problems about duplicate keys)."""
    try:
        with open(path, encoding="utf-8") as stream:
            text = stream.read()
    except OSError as error:
        reason = error.strerror or error
        raise CaseError([f"{path}: cannot read case file: {reason}"]) from None
    return parse_yaml(text, str(path))


def parse_value(text):
    """Parse a ``--set`` value as YAML (``0.38`` -> float, ``[0, 0, -190]`` -> list)."""
    data, _ = parse_yaml(text, "value")
    return data


def _one_line(error):
    return " ".join(str(error).split())
