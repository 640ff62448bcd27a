"""One owner for the regulatory weights and their combination.

``vehval/results/composites.py`` holds the FTP-75 weights (:data:`FTP_WEIGHTS`, 0.43 / 0.57)
and the combinations (:func:`weighted_per_distance`, :func:`weighted_reciprocal_sum`,
:func:`weighted_harmonic`); results, the EPA procedures, the list checks and the predictions
call them. Anywhere else the scan fails on:

* the weights written as numbers (0.43, 0.57);
* a weight used in arithmetic (``FTP_WEIGHT... / cold``);
* a weighted combination by hand: ``w / a + v / b`` with weights, or ``x += w * a / d``.

The scan reads the package with ``ast`` (docstrings and comments may explain the rule).
"""

from __future__ import annotations

import ast
import math
import re
from pathlib import Path

import numpy as np

from vehval.results.composites import (
    FTP_WEIGHTS,
    weighted_harmonic,
    weighted_per_distance,
    weighted_reciprocal_sum,
)

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
OWNER = Path("results") / "composites.py"
WEIGHTS = (0.43, 0.57)
WEIGHT_NAME = re.compile(r"^(w|w_\w+|\w*weights?\w*)$", re.I)


def _name(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Subscript):
        return _name(node.value)
    return ""


def _weighted_ratio(node: ast.AST) -> bool:
    """``w / x`` or ``w * a / d`` with a weight ``w``."""
    if not (isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div)):
        return False
    num = node.left
    if isinstance(num, ast.BinOp) and isinstance(num.op, ast.Mult):
        return bool(WEIGHT_NAME.match(_name(num.left)) or WEIGHT_NAME.match(_name(num.right)))
    return bool(WEIGHT_NAME.match(_name(num)))


def scan(root: Path = PKG) -> list[str]:
    """Every breach of the module docstring's rules under ``root``, as ``file:line: why``."""
    out = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel == OWNER:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            line = getattr(node, "lineno", 0)
            if isinstance(node, ast.Constant) and isinstance(node.value, float) \
                    and any(math.isclose(node.value, w) for w in WEIGHTS):
                out.append(f"{rel}:{line}: FTP weight {node.value!r} written in code "
                           "(vehval.results.composites.FTP_WEIGHTS)")
            elif isinstance(node, ast.BinOp) and any(
                    "FTP_WEIGHT" in _name(side) for side in (node.left, node.right)):
                out.append(f"{rel}:{line}: FTP weight in arithmetic (use "
                           "vehval.results.composites.weighted_*)")
            elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add) \
                    and _weighted_ratio(node.left) and _weighted_ratio(node.right):
                out.append(f"{rel}:{line}: weighted combination by hand (use "
                           "vehval.results.composites.weighted_*)")
            elif isinstance(node, ast.AugAssign) and isinstance(node.op, ast.Add) \
                    and _weighted_ratio(node.value):
                out.append(f"{rel}:{line}: weighted sum by hand (use "
                           "vehval.results.composites.weighted_per_distance)")
    return out


def test_no_second_owner_of_the_regulatory_weighting():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_each_kind_of_breach(tmp_path):
    pkg = tmp_path / "vehval"
    (pkg / "results").mkdir(parents=True)
    (pkg / "results" / "composites.py").write_text("FTP_WEIGHTS = (0.43, 0.57)\n")
    (pkg / "bad.py").write_text(
        "W_COLD = 0.43\n"
        "def f(cold, hot, groups, FTP_WEIGHT_HOT, w_cold, w_hot):\n"
        "    a = 1.0 / (w_cold / cold + w_hot / hot)\n"
        "    b = FTP_WEIGHT_HOT / hot\n"
        "    fpd = 0.0\n"
        "    for w, fm, dd in groups:\n"
        "        fpd += w * fm / dd\n"
        "    return a, b, fpd\n")
    text = "\n".join(scan(pkg))
    for why in ("FTP weight 0.43", "FTP weight in arithmetic", "weighted combination by hand",
                "weighted sum by hand"):
        assert why in text, (why, text)
    assert "composites.py" not in text


def test_the_combinations_agree():
    """Per distance and per amount give the same FTP figure (40 CFR 600.113 harmonic rule)."""
    fuel, dist = np.array([1.0, 0.9]), np.array([20e3, 21e3])   # kg, m of the cold / hot half
    per_m = weighted_per_distance(zip(FTP_WEIGHTS, fuel, dist))
    assert math.isclose(per_m, weighted_reciprocal_sum(FTP_WEIGHTS, dist / fuel))
    assert math.isclose(weighted_harmonic(FTP_WEIGHTS, dist / fuel), 1.0 / per_m)
    arr = weighted_per_distance([(0.5, np.ones(3), np.full(3, 2.0))])
    assert np.allclose(arr, 0.25)
