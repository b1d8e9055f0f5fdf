"""Small arithmetic expressions over case parameters, evaluated without ``eval``.

Allowed: numbers, parameter names, ``pi``, ``+ - * / **``, parentheses, unary minus and
the functions in ``FUNCTIONS``. The expression is parsed with :mod:`ast` and walked node
by node; any other syntax (attributes, subscripts, comparisons, keywords...) is refused.
"""
import ast
import math
import operator

from .errors import unknown_name

FUNCTIONS = {
    "sqrt": math.sqrt, "sin": math.sin, "cos": math.cos, "tan": math.tan,
    "radians": math.radians, "degrees": math.degrees, "abs": abs,
    "exp": math.exp, "log": math.log, "min": min, "max": max,
    "round": round, "floor": math.floor, "ceil": math.ceil,
}
CONSTANTS = {"pi": math.pi}
RESERVED = set(FUNCTIONS) | set(CONSTANTS)

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


def names_in(text):
    """The parameter names an expression refers to (empty if it does not parse)."""
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        return set()
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call)
              and isinstance(n.func, ast.Name)}
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} - called - RESERVED


def _walk(node, names):
    if isinstance(node, ast.Constant):
        return _number(node.value)
    if isinstance(node, ast.Name):
        return _lookup(node.id, names)
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return _BINARY[type(node.op)](_walk(node.left, names), _walk(node.right, names))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_walk(node.operand, names))
    if isinstance(node, ast.Call):
        return _call(node, names)
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


def _call(node, names):
    name = node.func.id if isinstance(node.func, ast.Name) else None
    if name not in FUNCTIONS or node.keywords:
        raise ExpressionError(f"unknown function '{ast.unparse(node.func)}'; known: "
                              + ", ".join(sorted(FUNCTIONS)))
    return FUNCTIONS[name](*(_walk(arg, names) for arg in node.args))
