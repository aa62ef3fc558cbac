"""Safe arithmetic expressions of one variable (jig curves in files): parsed, never executed.

Expressions are parsed with :mod:`ast` and evaluated by a small interpreter that knows only
numbers, the variable, ``pi``, ``+ - * / **``, unary minus, comparisons and the numpy
functions ``sin cos exp sqrt abs where``: no Python code is ever executed.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable

import numpy as np

#: Longest accepted expression (characters).
MAX_EXPRESSION_CHARS = 500


_BINOPS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: operator.pow}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}
_COMPARE = {ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge}
_FUNCS = {"sin": (np.sin, 1), "cos": (np.cos, 1), "exp": (np.exp, 1), "sqrt": (np.sqrt, 1), "abs": (np.abs, 1),
          "where": (np.where, 3)}
_CONSTS = {"pi": math.pi}


def compile_expression(text: str, *, name: str = "expression", variable: str = "x") -> Callable:
    """Compile an arithmetic expression of one variable into a vectorized function.

    Allowed: numbers, the variable, ``pi``, ``+ - * / **``, unary ``-``/``+``, the comparisons
    ``< <= > >=`` (for ``where``) and the functions ``sin cos exp sqrt abs where``. Anything
    else (attribute access, names, subscripts, keywords, lambdas, ...) raises ValueError
    naming ``name``, and so does evaluating it where it is not finite. Nothing is passed to
    ``eval``.

    Examples
    --------
    >>> f = compile_expression("where(x < 20, -0.2*(x-10)**2 + 20, -10*sin(0.2*pi*(x-20)))")
    >>> float(f(10.0))
    20.0
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"{name} must be a non-empty expression string in {variable!r}, got {text!r}.")
    if len(text) > MAX_EXPRESSION_CHARS:
        raise ValueError(f"{name} must be at most {MAX_EXPRESSION_CHARS} characters, got {len(text)}.")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise ValueError(f"{name} is not a valid expression: {text!r} ({exc.msg}).") from None
    _check_node(tree.body, name, variable)

    def f(x):
        x = np.asarray(x, dtype=float)
        with np.errstate(all="ignore"):
            out = np.asarray(_eval(tree.body, x, variable), dtype=float) + np.zeros_like(x)
        if not np.all(np.isfinite(out)):
            bad = x[~np.isfinite(out)] if out.shape == x.shape and x.ndim else x
            raise ValueError(
                f"{name} = {text!r} gives non-finite values (overflow, or sqrt of a negative number), "
                f"e.g. at {variable} = {np.ravel(bad)[0]:g}."
            )
        return out

    f.__doc__ = f"z = {text}"
    f.expression, f.variable = text.strip(), variable  # read back when a jig is saved to a robot file
    return f


def _check_node(node, name: str, var: str) -> None:
    bad = None
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            bad = f"the constant {node.value!r}"
    elif isinstance(node, ast.Name):
        if node.id != var and node.id not in _CONSTS:
            bad = f"the name {node.id!r} (only {var!r} and {sorted(_CONSTS)} are known)"
    elif isinstance(node, ast.BinOp):
        if type(node.op) not in _BINOPS:
            bad = f"the operator {type(node.op).__name__}"
        else:
            _check_node(node.left, name, var)
            _check_node(node.right, name, var)
    elif isinstance(node, ast.UnaryOp):
        if type(node.op) not in _UNARY:
            bad = f"the operator {type(node.op).__name__}"
        else:
            _check_node(node.operand, name, var)
    elif isinstance(node, ast.Compare):
        if any(type(op) not in _COMPARE for op in node.ops):
            bad = "a comparison other than < <= > >="
        else:
            for n in (node.left, *node.comparators):
                _check_node(n, name, var)
    elif isinstance(node, ast.Call):
        fname = node.func.id if isinstance(node.func, ast.Name) else None
        if fname not in _FUNCS:
            bad = f"a call to {ast.unparse(node.func)!r} (allowed functions: {sorted(_FUNCS)})"
        elif node.keywords:
            bad = f"keyword arguments in {fname}()"
        elif len(node.args) != _FUNCS[fname][1]:
            bad = f"{fname}() with {len(node.args)} arguments (expects {_FUNCS[fname][1]})"
        else:
            for a in node.args:
                _check_node(a, name, var)
    else:
        bad = f"{type(node).__name__} syntax"
    if bad:
        raise ValueError(
            f"{name} may use only numbers, {var!r}, pi, + - * / **, comparisons and "
            f"{', '.join(sorted(_FUNCS))}; it contains {bad}."
        )


def _eval(node, x, var):
    if isinstance(node, ast.Constant):
        return float(node.value)  # floats, so 10**10**10 overflows to inf instead of hanging
    if isinstance(node, ast.Name):
        return x if node.id == var else _CONSTS[node.id]
    if isinstance(node, ast.BinOp):
        return _BINOPS[type(node.op)](np.float64(1.0) * _eval(node.left, x, var), _eval(node.right, x, var))
    if isinstance(node, ast.UnaryOp):
        return _UNARY[type(node.op)](_eval(node.operand, x, var))
    if isinstance(node, ast.Compare):
        left = _eval(node.left, x, var)
        out = True
        for op, comp in zip(node.ops, node.comparators, strict=True):
            right = _eval(comp, x, var)
            out = np.logical_and(out, _COMPARE[type(op)](left, right))
            left = right
        return out
    fn, _ = _FUNCS[node.func.id]
    return fn(*[_eval(a, x, var) for a in node.args])


__all__ = ["MAX_EXPRESSION_CHARS", "compile_expression"]
