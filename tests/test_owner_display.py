"""One owner for display conversions: :mod:`vehval.display` (``as_unit``, ``to_display``,
``unit_for``, ``percent``) turns SI values into what a person reads.

In the code that lays out pages, plots and tables (``report/``, ``serve/``, ``analysis/``,
``batch/``, ``identify/report.py``, ``sim/sensitivity.py``) a product or quotient with a
display factor written by hand (``* 1e3`` kg/s -> g/s, ``/ 1e3`` W -> kW, ``/ 1e6`` J -> MJ,
``100 *`` a fraction, ``3.6``, ``2.23694``, ``1.609``, ``0.44704``, ``0.4536``...) fails with
the file and line. A line that multiplies by such a number for another reason says so with
the comment ``not a unit conversion``. The scan reads the sources with ``ast`` (no import).
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from vehval import display

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
SCANNED = ("report", "serve", "analysis", "batch", "identify/report.py", "sim/sensitivity.py")
FACTORS = (1e3, 1e-3, 1e6, 1e-6, 100.0, 3.6, 1 / 3.6, 2.23694, 1.609344, 1.609, 0.44704,
           0.621371, 0.45359237, 2.20462)
MARK = "not a unit conversion"


def _factor(node: ast.AST) -> bool:
    return (isinstance(node, ast.Constant) and isinstance(node.value, (int, float))
            and not isinstance(node.value, bool)
            and any(abs(float(node.value) - f) <= 1e-6 * f for f in FACTORS))


def scan(root: Path = PKG, scanned: tuple[str, ...] = SCANNED) -> list[str]:
    """Every display conversion written by hand under ``scanned``, as ``file:line: code``."""
    out: set[str] = set()
    for part in scanned:
        base = root / part
        for path in ([base] if base.is_file() else sorted(base.rglob("*.py"))):
            text = path.read_text(encoding="utf-8")
            lines = text.splitlines()
            for node in ast.walk(ast.parse(text)):
                if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)) \
                        and (_factor(node.left) or _factor(node.right)) \
                        and MARK not in lines[node.lineno - 1]:
                    out.add(f"{path.relative_to(root)}:{node.lineno}: {ast.unparse(node)[:60]}"
                            " (convert with vehval.display.as_unit / to_display)")
    return sorted(out)


def test_no_display_conversion_by_hand():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_each_spelling(tmp_path):
    pkg = tmp_path / "vehval"
    (pkg / "report").mkdir(parents=True)
    (pkg / "report" / "bad.py").write_text(
        "def f(w, x, v, d):\n"
        "    a = w / 1e3\n"
        "    b = 100 * x\n"
        "    c = v * 2.23694\n"
        "    e = d / 1.609344\n"
        "    g = x * 1000.0\n"
        "    ok = x * 100  # a step, not a unit conversion\n"
        "    ok2 = x * 7.0 + 100\n"
        "    return a, b, c, e, g, ok, ok2\n")
    found = scan(pkg, ("report",))
    assert [f.split(":")[1] for f in found] == ["2", "3", "4", "5", "6"], found


def test_as_unit_is_the_table():
    assert display.as_unit(0.0021, "g/s") == pytest.approx(2.1)
    assert display.as_unit(0.25, "%") == pytest.approx(25.0)
    assert display.as_unit(3.6e6, "kWh") == pytest.approx(1.0)
    assert display.as_unit(1609.344, "mi") == pytest.approx(1.0)
    assert np.allclose(display.as_unit(np.array([1e3, 2e3]), "kW"), [1.0, 2.0])
    # the fixed units agree with the unit-system table where both name the unit
    for label, (si, factor) in display.FIXED.items():
        for system in display.SYSTEMS:
            row = display.TABLE.get(si, {}).get(system)
            if row is not None and row.label == label:
                assert row.factor == pytest.approx(factor), label
    with pytest.raises(ValueError, match="known"):
        display.as_unit(1.0, "furlong")
