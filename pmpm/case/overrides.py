"""``--set KEY=VALUE`` overrides applied to the raw case before substitution.

KEY is a dotted path; list items are named ``bodies.0.velocity`` or
``bodies[0].velocity``. VALUE is parsed as YAML (``0.38``, ``[0, 0, -190]``, ``fixed``).
Missing mappings on the way are created; list items must already exist.
"""
import re

from .errors import CaseError, describe, join
from .yamlio import parse_value

_KEY = re.compile(r"^[^.\[\]=]+(\[\d+\])*(\.[^.\[\]=]+(\[\d+\])*)*$")
_TOKEN = re.compile(r"\[(\d+)\]|([^.\[\]]+)")


def apply_overrides(tree, overrides, problems):
    """Apply each ``"KEY=VALUE"`` string of ``overrides`` to ``tree`` in place."""
    for item in [overrides] if isinstance(overrides, str) else overrides:
        key, sep, text = str(item).partition("=")
        key = key.strip()
        if not sep or not _KEY.match(key):
            problems.add(f"--set {item}", "expected KEY=VALUE with a dotted KEY "
                         "(e.g. params.cell=0.38, bodies[0].velocity=[0,0,-190])")
            continue
        try:
            value = parse_value(text)
        except CaseError as error:
            problems.add(_path(parse_key(key)), f"--set: value {text!r}: {error}")
            continue
        _assign(tree, parse_key(key), value, problems)


def parse_key(key):
    """``"bodies[0].velocity"`` or ``"bodies.0.velocity"`` -> ``["bodies", 0, "velocity"]``."""
    tokens = []
    for index, name in _TOKEN.findall(key):
        token = index or name
        tokens.append(int(token) if token.isdigit() else token)
    return tokens


def _assign(tree, tokens, value, problems):
    node = tree
    for depth, token in enumerate(tokens[:-1]):
        node = _child(node, token, tokens[depth + 1], _path(tokens[:depth + 1]), problems)
        if node is None:
            return
    last = tokens[-1]
    if isinstance(node, list):
        if _index_ok(node, last, _path(tokens), problems):
            node[last] = value
    else:
        node[_dict_key(node, last)] = value


def _child(node, token, next_token, path, problems):
    if isinstance(node, list):
        return node[token] if _index_ok(node, token, path, problems) else None
    if not isinstance(node, dict):
        problems.add(path, f"--set: the parent is {describe(node)}, not a mapping or list")
        return None
    key = _dict_key(node, token)
    if node.get(key) is None:
        if isinstance(next_token, int):
            problems.add(join(path, next_token), f"--set: no list at {path} to index")
            return None
        node[key] = {}
    child = node[key]
    if not isinstance(child, (dict, list)):
        problems.add(path, f"--set: {describe(child)} is not a mapping or list")
        return None
    return child


def _index_ok(node, token, path, problems):
    if isinstance(token, int) and token < len(node):
        return True
    problems.add(path, f"--set: no item {token!r} (the list has {len(node)} items, "
                 f"numbered from 0)")
    return False


def _dict_key(node, token):
    if isinstance(token, int) and token not in node:
        return str(token)
    return token


def _path(tokens):
    path = ""
    for token in tokens:
        path = join(path, token)
    return path
