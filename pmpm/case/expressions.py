"""Small arithmetic expressions over case parameters, evaluated without ``eval``.

Allowed: numbers, parameter names, ``pi``, ``+ - * / **``, parentheses, unary minus and
the functions in ``FUNCTIONS``. The expression is parsed with :mod:`ast` and walked node
by node; any other syntax (attributes, subscripts, comparisons, keywords...) is refused.
"""
import ast
import math
import operator

import numpy as np

from .errors import unknown_name

FUNCTIONS = {
    "sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan,
    "radians": math.radians, "degrees": math.degrees, "abs": abs,
    "exp": math.exp, "log": math.log, "min": min, "max": max,
    "round": round, "floor": math.floor, "ceil": math.ceil,
}
#: the same functions on arrays, for fields of position (:func:`evaluate_field`)
ARRAY_FUNCTIONS = {
    "sqrt": np.sqrt, "sin": np.sin, "cos": np.cos, "tan": np.tan,
    "radians": np.radians, "degrees": np.degrees, "abs": np.abs,
    "exp": np.exp, "log": np.log, "min": np.minimum, "max": np.maximum,
    "round": np.round, "floor": np.floor, "ceil": np.ceil,
}
CONSTANTS = {"pi": math.pi}
RESERVED = set(FUNCTIONS) | set(CONSTANTS)
COORDINATES = ("x", "y", "z")

_BINARY = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
    ast.Div: operator.truediv, ast.Pow: lambda a, b: float(a) ** b,
}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}


class ExpressionError(ValueError):
    """An expression that is not allowed or cannot be evaluated; the message says why."""


def evaluate(text, names):
    """Value of the expression ``text`` with parameter values ``names`` (a dict)."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise ExpressionError(f"invalid expression {text!r}") from None
    try:
        value = _walk(tree.body, names)
    except (ArithmeticError, ValueError, TypeError) as error:
        if isinstance(error, ExpressionError):
            raise
        raise ExpressionError(f"cannot evaluate {text!r}: {error}") from None
    if isinstance(value, complex) or not math.isfinite(value):
        raise ExpressionError(f"{text!r} does not give a finite real number")
    return value


def _parsed(text):
    """The expression's syntax tree, or None when it does not parse."""
    try:
        return ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        return None


def check_field(text):
    """Problem with a field expression of x, y, z (a message), or None when it is one."""
    tree = _parsed(text)
    if tree is None:
        return f"invalid expression {text!r}"
    unknown = sorted(names_in(text) - set(COORDINATES))
    if unknown:
        return (f"{text!r} refers to {', '.join(unknown)}: a field may use x, y, z and pi "
                "(write parameters as ${name})")
    try:
        with np.errstate(all="ignore"):
            _walk(tree.body, dict(zip(COORDINATES, np.zeros((3, 1)))), ARRAY_FUNCTIONS)
    except ExpressionError as error:
        return str(error)
    except (ArithmeticError, ValueError, TypeError):
        pass                    # a domain error at the origin: judged where it is used
    return None


def evaluate_field(text, x):
    """The field expression ``text`` at the positions ``x`` (n, 3): float64 (n,).
    Raises ExpressionError when a value is not finite."""
    tree = ast.parse(text.strip(), mode="eval")
    names = dict(zip(COORDINATES, np.asarray(x, np.float64).T))
    with np.errstate(all="ignore"):
        values = np.broadcast_to(_walk(tree.body, names, ARRAY_FUNCTIONS),
                                 (len(x),)).astype(np.float64)
    if not np.all(np.isfinite(values)):
        raise ExpressionError(f"{text!r} is not finite at some particles of the body")
    return values


def names_in(text):
    """The parameter names an expression refers to (empty if it does not parse)."""
    tree = _parsed(text)
    if tree is None:
        return set()
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call)
              and isinstance(n.func, ast.Name)}
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} - called - RESERVED


def _walk(node, names, functions=FUNCTIONS):
    if isinstance(node, ast.Constant):
        return _number(node.value)
    if isinstance(node, ast.Name):
        return _lookup(node.id, names)
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        left, right = _walk(node.left, names, functions), _walk(node.right, names, functions)
        if isinstance(node.op, ast.Pow) and functions is ARRAY_FUNCTIONS:
            return np.power(np.asarray(left, np.float64), right)
        return _BINARY[type(node.op)](left, right)
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_walk(node.operand, names, functions))
    if isinstance(node, ast.Call):
        return _call(node, names, functions)
    raise ExpressionError(f"'{ast.unparse(node)}' is not allowed (only numbers, parameters, "
                          "+ - * / **, parentheses and " + ", ".join(sorted(FUNCTIONS)) + ")")


def _number(value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ExpressionError(f"{value!r} is not a number")
    return value


def _lookup(name, names):
    if name in names:
        return names[name]
    if name in CONSTANTS:
        return CONSTANTS[name]
    raise ExpressionError(unknown_name("parameter", name, names))


def _call(node, names, functions=FUNCTIONS):
    name = node.func.id if isinstance(node.func, ast.Name) else None
    if name not in functions or node.keywords:
        raise ExpressionError(f"unknown function '{ast.unparse(node.func)}'; known: "
                              + ", ".join(sorted(functions)))
    return functions[name](*(_walk(arg, names, functions) for arg in node.args))
