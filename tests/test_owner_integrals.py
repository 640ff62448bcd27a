"""One owner for whole-test integrals and battery power: ``vehval/integrals.py``.

The scan reads the package with ``ast`` (no import) and fails with the file and line on:

* a call of ``trapezoid`` / ``trapz`` / ``cumulative_trapezoid`` / ``cumtrapz`` (numpy or scipy);
* a trapezoid written by hand: a product that holds ``x[1:]``, ``x[:-1]`` and ``diff(...)``
  (``0.5 * (v[1:] + v[:-1]) * np.diff(t)``);
* a zero-order-hold sum written by hand: ``np.sum(x[sel]) * dt`` or ``x[sel].sum() * dt``
  (the sum of an expression, not of a bare mask name, which counts samples, times a step
  named ``dt`` / ``step``);
* battery power written by hand: a product of a voltage (a name holding ``volt`` or ``ocv``)
  and a current (a name holding ``curr``).

The simulator's kernels accumulate their own totals step by step in compiled loops (they
cannot call Python); they use other names and are not matched.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

from vehval.integrals import (
    battery_energy,
    battery_power,
    cumulative,
    held_sum,
    integral,
    window_integral,
)

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
OWNER = Path("integrals.py")
CALLS = {"trapezoid", "trapz", "cumulative_trapezoid", "cumtrapz"}
STEP = re.compile(r"^(dt|dt_s|step|step_s)$")


def _leaves(node: ast.AST) -> list[ast.AST]:
    """Operands of a chain of ``*`` (not through ``+``, ``-`` or calls)."""
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        return _leaves(node.left) + _leaves(node.right)
    return [node]


def _hand_trapezoid(node: ast.BinOp) -> bool:
    text = ast.unparse(node)
    return "[1:]" in text and "[:-1]" in text and "diff(" in text


def _summed(node: ast.AST) -> ast.AST | None:
    """What ``np.sum(x)`` / ``x.sum()`` (no axis) sums, else None."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
            and node.func.attr == "sum" and not node.keywords:
        if node.args and len(node.args) == 1:
            return node.args[0]
        if not node.args:
            return node.func.value
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "float" \
            and node.args:
        return _summed(node.args[0])
    return None


def _hand_held_sum(node: ast.BinOp) -> bool:
    leaves = _leaves(node)
    step = any(STEP.match(ast.unparse(x)) for x in leaves)
    summed = [_summed(x) for x in leaves]
    return step and any(x is not None and not _mask(x) for x in summed)


def _mask(node: ast.AST) -> bool:
    """A bare name or its negation (``sel``, ``~keep``): summing it counts samples."""
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Invert):
        node = node.operand
    return isinstance(node, ast.Name)


def _hand_battery_power(node: ast.BinOp) -> bool:
    texts = [ast.unparse(x).lower() for x in _leaves(node)]
    volt = [i for i, x in enumerate(texts) if "volt" in x or "ocv" in x]
    curr = [i for i, x in enumerate(texts) if "curr" in x]
    return any(i != j for i in volt for j in curr)


def scan(root: Path = PKG) -> list[str]:
    """Every integral or battery power written outside the owner, as ``file:line: why``."""
    out: set[str] = set()
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel == OWNER:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call):
                f = node.func
                name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
                if name in CALLS:
                    out.add(f"{rel}:{node.lineno}: {name}() (use vehval.integrals)")
            elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
                if _hand_trapezoid(node):
                    out.add(f"{rel}:{node.lineno}: trapezoid by hand (use vehval.integrals)")
                elif _hand_held_sum(node):
                    out.add(f"{rel}:{node.lineno}: held sum by hand (use vehval.integrals.held_sum)")
                elif _hand_battery_power(node):
                    out.add(f"{rel}:{node.lineno}: voltage x current by hand "
                            "(use vehval.integrals.battery_power)")
    return sorted(out)


def test_no_second_integral_or_battery_power():
    assert scan() == []


def test_scan_sees_each_kind_of_copy(tmp_path):
    (tmp_path / "a.py").write_text(
        "import numpy as np\n"
        "x = np.trapezoid(v, t)\n"
        "y = float(np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t)))\n"
        "p = ess_volt.values * ess_curr.values\n"
        "q = np.interp(soc, b.soc, b.ocv_v) * out[:, col['ess_curr']]\n"
        "f = float(np.sum(fuel[keep]) * dt)\n"
        "g = fuel_meas[sel].sum() * dt * 1e3\n"
        "ok = speed * dt\n"
        "duration = sel.sum() * dt + np.sum(~keep) * dt\n", encoding="utf-8")
    found = scan(tmp_path)
    assert [f.split(":")[1] for f in found] == ["2", "3", "4", "5", "6", "7"], found


def test_integral_bridges_gaps_and_needs_two_samples():
    t = np.arange(5.0)
    assert integral(t, np.full(5, 2.0)) == pytest.approx(8.0)
    # a dropout is bridged by its neighbours, not counted as zero
    assert integral(t, [2.0, 2.0, np.nan, 2.0, 2.0]) == pytest.approx(8.0)
    assert np.isnan(integral(t, [np.nan, 1.0, np.nan, np.nan, np.nan]))
    assert np.isnan(integral([0.0], [1.0]))


def test_cumulative_keeps_the_shape_and_ends_at_the_integral():
    t = np.arange(6.0)
    v = np.array([np.nan, 1.0, 1.0, np.nan, 1.0, np.nan])
    c = cumulative(t, v)
    assert c.shape == v.shape
    assert c[0] == 0.0 and c[-1] == pytest.approx(integral(t, v)) == pytest.approx(3.0)
    assert np.all(np.diff(c) >= 0)


def test_window_integral_trapezoid_and_held_step():
    t = np.arange(11.0)
    v = t.copy()  # integral of t from a to b = (b^2 - a^2) / 2
    assert window_integral(t, v, [(2.0, 5.0)]) == pytest.approx((25 - 4) / 2)
    assert window_integral(t, v, [(0.0, 2.0), (8.0, None)]) == pytest.approx(2.0 + 18.0)
    # a simulator's held steps: samples with a <= t < b, times the step
    assert window_integral(t, v, [(2.0, 5.0)], step_s=1.0) == pytest.approx(2 + 3 + 4)
    assert window_integral(t, v, [(8.0, None)], step_s=1.0) == pytest.approx(8 + 9 + 10)


def test_battery_power_is_positive_discharging():
    t = np.arange(3.0)
    volt, curr = np.full(3, 200.0), np.array([10.0, 10.0, -10.0])  # discharge, then charge
    assert battery_power(volt, curr).tolist() == [2000.0, 2000.0, -2000.0]
    assert battery_energy(t, volt, curr) == pytest.approx(2000.0 + 0.0)


def test_held_sum_is_the_window_integral_of_a_held_step():
    t, v = np.arange(6.0), np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert held_sum(v, 0.5) == pytest.approx(10.5)
    assert held_sum(v, 0.5, t >= 3) == pytest.approx(7.5)
    assert held_sum(v, 0.5, t >= 3) == window_integral(t, v, [(3.0, None)], step_s=0.5)
