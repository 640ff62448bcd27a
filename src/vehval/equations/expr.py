"""A small safe expression language for calculation files.

Expressions are parsed with :mod:`ast` and only these nodes are evaluated: numbers, names
(signals on the calculation grid, parameters, ``t`` the grid time [s]), ``+ - * / **``,
unary ``-``/``+``, comparisons (``< <= > >= == !=``, giving boolean arrays) and calls of the
whitelisted functions in :data:`FUNCTIONS` with positional arguments. Anything else (attribute
access, subscripts, lambdas, keywords, strings...) is rejected: nothing is ever passed to
``eval``.

Limits (each breach is a :class:`ConfigError` naming the expression): the number of
arguments of every function (:data:`ARITY`), an exponent must be a number of magnitude at
most :data:`MAX_EXPONENT`, nesting at most :data:`MAX_DEPTH` levels, text at most
:data:`MAX_LENGTH` characters, and a ``smooth`` window within (0, :data:`MAX_WINDOW_S`] s.
"""

from __future__ import annotations

import ast
import operator
from functools import lru_cache
from typing import Callable, Mapping

import numpy as np

from vehval.equations import powertrain as pt
from vehval.errors import ConfigError

_BIN = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
        ast.Div: operator.truediv, ast.Pow: operator.pow}
_UN = {ast.USub: operator.neg, ast.UAdd: operator.pos}
_CMP = {ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge,
        ast.Eq: operator.eq, ast.NotEq: operator.ne}


def _safe_div(a, b, min_abs=0.0):
    a, b = np.asarray(a, float), np.asarray(b, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.abs(b) > min_abs, a / np.where(b == 0, np.nan, b), np.nan)


#: Whitelisted functions; those needing the grid time receive it as first argument.
FUNCTIONS: dict[str, tuple[Callable, bool]] = {
    "deriv": (pt.deriv, True),            # deriv(x): d x / d t
    "cumint": (pt.cumint, True),          # cumint(x): ∫ x dt from the start
    "smooth": (pt.smooth, True),          # smooth(x, window_s): centred moving average
    "where": (lambda c, a, b: np.where(c, a, b), False),
    "abs": (np.abs, False),
    "sqrt": (np.sqrt, False),
    "sign": (np.sign, False),
    "minimum": (np.minimum, False),
    "maximum": (np.maximum, False),
    "clip": (np.clip, False),
    "safe_div": (_safe_div, False),       # safe_div(a, b, min_abs): NaN where |b| <= min_abs
}


#: Accepted number of positional arguments per function (min, max).
ARITY: dict[str, tuple[int, int]] = {
    "deriv": (1, 1), "cumint": (1, 1), "smooth": (2, 2), "where": (3, 3), "abs": (1, 1),
    "sqrt": (1, 1), "sign": (1, 1), "minimum": (2, 2), "maximum": (2, 2), "clip": (3, 3),
    "safe_div": (2, 3),
}
#: Largest |exponent| of ``**`` (a constant); powertrain relations use squares and cubes.
MAX_EXPONENT = 10.0
#: Deepest nesting of operations and calls.
MAX_DEPTH = 40
#: Longest expression text [characters].
MAX_LENGTH = 2000
#: Longest ``smooth`` window [s].
MAX_WINDOW_S = 3600.0


def _constant_value(node: ast.AST) -> float | None:
    """The value of a number literal, possibly signed; None for anything else."""
    sign = 1.0
    while isinstance(node, ast.UnaryOp) and type(node.op) in _UN:
        sign = -sign if isinstance(node.op, ast.USub) else sign
        node = node.operand
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) \
            and not isinstance(node.value, bool):
        return sign * float(node.value)
    return None


def _check_window(value: float, where: str, text: str) -> None:
    if not (np.isfinite(value) and 0 < value <= MAX_WINDOW_S):
        raise ConfigError(f"{where}: smooth window {value:g} s in '{text}' is outside "
                          f"(0, {MAX_WINDOW_S:g}] s: give a window of a few seconds")


class Expression:
    """A parsed, validated expression.

    Attributes
    ----------
    text : str
        The source text.
    names : frozenset of str
        Every variable name it uses (signals, parameters, ``t``).
    """

    def __init__(self, text: str, where: str = "expression") -> None:
        self.text = text
        if len(text) > MAX_LENGTH:
            raise ConfigError(f"{where}: expression of {len(text)} characters is too long "
                              f"(limit {MAX_LENGTH})")
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except SyntaxError as exc:
            raise ConfigError(f"{where}: cannot parse '{text[:80]}': {exc.msg} (too deep "
                              "nesting?)") from None
        except (RecursionError, MemoryError, ValueError):
            raise ConfigError(f"{where}: cannot parse '{text[:80]}': nesting too deep") from None
        names: set[str] = set()
        self._check(tree.body, where, names)
        self.tree = tree.body
        self.names = frozenset(names)

    def _check(self, node: ast.AST, where: str, names: set[str], depth: int = 0) -> None:  # noqa: C901, PLR0912 - one branch per allowed node type of a relation
        if depth > MAX_DEPTH:
            raise ConfigError(f"{where}: '{self.text[:80]}' is nested too deep (more than "
                              f"{MAX_DEPTH} levels): split it into several relations")
        depth += 1
        if isinstance(node, ast.Constant):
            if not isinstance(node.value, (int, float)) or isinstance(node.value, bool):
                raise ConfigError(f"{where}: only numbers are allowed as constants in '{self.text}'")
        elif isinstance(node, ast.Name):
            if node.id in FUNCTIONS:
                raise ConfigError(f"{where}: '{node.id}' is a function; call it with arguments")
            names.add(node.id)
        elif isinstance(node, ast.BinOp) and type(node.op) in _BIN:
            if isinstance(node.op, ast.Pow):
                exp = _constant_value(node.right)
                if exp is None or abs(exp) > MAX_EXPONENT:
                    raise ConfigError(f"{where}: the exponent in '{self.text[:80]}' must be a "
                                      f"number of magnitude at most {MAX_EXPONENT:g}")
            self._check(node.left, where, names, depth)
            self._check(node.right, where, names, depth)
        elif isinstance(node, ast.UnaryOp) and type(node.op) in _UN:
            self._check(node.operand, where, names, depth)
        elif isinstance(node, ast.Compare) and len(node.ops) == 1 and type(node.ops[0]) in _CMP:
            self._check(node.left, where, names, depth)
            self._check(node.comparators[0], where, names, depth)
        elif isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                fn = getattr(node.func, "id", ast.dump(node.func))
                raise ConfigError(f"{where}: function '{fn}' is not allowed in '{self.text}'; "
                                  f"use one of {', '.join(sorted(FUNCTIONS))}")
            if node.keywords:
                raise ConfigError(f"{where}: keyword arguments are not allowed in '{self.text}'")
            lo, hi = ARITY[node.func.id]
            if not lo <= len(node.args) <= hi:
                n = f"{lo}" if lo == hi else f"{lo} to {hi}"
                raise ConfigError(f"{where}: {node.func.id}() takes {n} argument(s), "
                                  f"{len(node.args)} given in '{self.text[:80]}'")
            if node.func.id == "smooth":
                window = _constant_value(node.args[1])
                if window is not None:
                    _check_window(window, where, self.text)
            for arg in node.args:
                self._check(arg, where, names, depth)
        else:
            raise ConfigError(f"{where}: '{type(node).__name__}' is not allowed in '{self.text}' "
                              "(only arithmetic, comparisons and whitelisted functions)")

    def evaluate(self, variables: Mapping[str, object], time: np.ndarray) -> np.ndarray:
        """Evaluate with ``variables`` (arrays on ``time`` or scalars) and grid ``time`` [s]."""
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            try:
                out = self._eval(self.tree, variables, time)
            except OverflowError:
                raise ConfigError(f"'{self.text[:80]}' overflows: check its parameters") from None
        return np.broadcast_to(np.asarray(out, float), time.shape).copy()

    def _eval(self, node, var, time):
        if isinstance(node, ast.Constant):
            return float(node.value)
        if isinstance(node, ast.Name):
            if node.id == "t" and "t" not in var:
                return time
            return var[node.id]
        if isinstance(node, ast.BinOp):
            return _BIN[type(node.op)](self._eval(node.left, var, time), self._eval(node.right, var, time))
        if isinstance(node, ast.UnaryOp):
            return _UN[type(node.op)](self._eval(node.operand, var, time))
        if isinstance(node, ast.Compare):
            return _CMP[type(node.ops[0])](self._eval(node.left, var, time),
                                           self._eval(node.comparators[0], var, time))
        fn, needs_time = FUNCTIONS[node.func.id]
        args = [self._eval(a, var, time) for a in node.args]
        if node.func.id == "smooth":
            window = np.asarray(args[1], float)
            if window.size != 1:
                raise ConfigError(f"smooth window in '{self.text[:80]}' must be one number")
            _check_window(float(window), "expression", self.text)
        if needs_time:
            args = [time, np.broadcast_to(np.asarray(args[0], float), time.shape)] + args[1:]
        return fn(*args)


@lru_cache(maxsize=512)
def parse_expression(text: str, where: str = "expression") -> Expression:
    """Parse (cached) an expression; :class:`ConfigError` names ``where`` on any problem."""
    return Expression(text, where)
