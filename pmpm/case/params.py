"""Case parameters (``params:``) and ``${expr}`` substitution everywhere else.

A parameter is a number or a ``"${expr}"`` string over other parameters (resolved in
dependency order). Elsewhere, a string that is exactly ``"${expr}"`` becomes the value
of ``expr``; ``${expr}`` inside longer text is replaced by the value's text.
"""
import math
import re

from .errors import join
from .expressions import RESERVED, ExpressionError, evaluate, names_in
from .fields import INVALID, as_number

PATTERN = re.compile(r"\$\{([^{}]*)\}")
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def resolve_params(raw, problems):
    """Validated ``{name: number}`` from the raw ``params`` mapping; a parameter whose
    problem has been reported maps to INVALID, so its uses report nothing more."""
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        problems.add("params", "expected a mapping of name: number")
        return {}
    pending = {name: value for name, value in raw.items() if _valid_name(name, problems)}
    values = {}
    while pending:
        ready = [n for n, v in pending.items() if not _depends_on(v, set(pending) - {n})]
        if not ready:
            problems.add("params", "parameters refer to each other in a cycle: "
                         + ", ".join(sorted(pending)))
            values.update(dict.fromkeys(pending, INVALID))
            break
        for name in ready:
            values[name] = _param_value(pending.pop(name), f"params.{name}", values, problems)
    return values


def substitute(tree, values, problems, path=""):
    """Copy of ``tree`` with every ``${expr}`` replaced; failures become INVALID."""
    if isinstance(tree, dict):
        return {k: substitute(v, values, problems, join(path, k)) for k, v in tree.items()}
    if isinstance(tree, list):
        return [substitute(v, values, problems, join(path, i)) for i, v in enumerate(tree)]
    if isinstance(tree, str) and "${" in tree:
        return _substitute_text(tree, values, problems, path)
    return tree


def _valid_name(name, problems):
    path = f"params.{name}"
    if not isinstance(name, str) or not _IDENTIFIER.match(name):
        problems.add(path, "a parameter name must be letters, digits and _, not starting "
                     "with a digit")
        return False
    if name in RESERVED:
        problems.add(path, f"{name!r} is reserved (a function or constant of expressions)")
        return False
    return True


def _depends_on(value, names):
    if not isinstance(value, str):
        return False
    return any(names_in(expr) & names for expr in PATTERN.findall(value))


def _param_value(value, path, values, problems):
    if isinstance(value, str) and "${" in value:
        value = _substitute_text(value, values, problems, path)
    if value is INVALID:
        return INVALID
    number = as_number(value)
    if number is None or not math.isfinite(number):
        problems.add(path, f"a parameter must be a finite number, got {value!r}")
        return INVALID
    return number


def _substitute_text(text, values, problems, path):
    if _uses_invalid(text, values):
        return INVALID
    try:
        whole = PATTERN.fullmatch(text)
        if whole:
            return evaluate(whole.group(1), values)
        result = PATTERN.sub(lambda m: _as_text(evaluate(m.group(1), values)), text)
    except ExpressionError as error:
        problems.add(path, f"{error} (in {text!r})")
        return INVALID
    if "${" in result:
        problems.add(path, f"unterminated or nested '${{' in {text!r}")
        return INVALID
    return result


def _uses_invalid(text, values):
    """Whether ``text`` refers to a parameter whose problem is already reported."""
    return any(values.get(name) is INVALID
               for expr in PATTERN.findall(text) for name in names_in(expr))


def _as_text(value):
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return str(value)
