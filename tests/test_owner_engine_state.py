"""One rule for the engine's state from measured data, one for a cold start.

* Engine on: :mod:`vehval.equations.engine_state` (on above 400 rpm, off below 250 rpm,
  0.5 s debounce; the fuel rate the same way without a speed). The analysis modes, the
  validation's engine-on share and starts, and the QA checks that judge a running engine
  use it. Elsewhere the scan fails on an engine speed compared with a threshold
  (``spd > 400 * RPM``), an engine-stopped / engine-on speed constant, or an rpm threshold
  written as a default (``on_speed_rpm: float = 400.0``).
* Cold start: :func:`vehval.conditions.cold_start` (coolant at most 10 K above the cell).
  Elsewhere the scan fails on a ``COLD_...`` threshold written as a number or compared.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np

from vehval.conditions import cold_start
from vehval.equations.engine_state import detect_engine_on

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
ENGINE_OWNER = Path("equations") / "engine_state.py"
COLD_OWNER = Path("conditions.py")
SPEED = re.compile(r"(spd|speed|w_eng|rpm)", re.I)
RPM_FACTOR = re.compile(r"^(RPM|RPM_RAD_PER_S)$")
ENGINE_CONST = re.compile(r"^ENGINE_(STOPPED|ON|OFF|RUNNING)\w*$")


def _names(node: ast.AST) -> set[str]:
    out = set()
    for n in ast.walk(node):
        if isinstance(n, ast.Name):
            out.add(n.id)
        elif isinstance(n, ast.Attribute):
            out.add(n.attr)
    return out


def _speed_threshold(node: ast.Compare) -> bool:
    """``speed > N * RPM``: an engine speed against an rpm threshold."""
    sides = [node.left, *node.comparators]
    return any(SPEED.search(" ".join(_names(s))) for s in sides) and any(
        isinstance(s, ast.BinOp) and isinstance(s.op, ast.Mult)
        and any(RPM_FACTOR.match(n) for n in _names(s)) for s in sides)


def scan(root: Path = PKG) -> list[str]:  # noqa: C901 - one branch per rule above
    """Every second engine-on or cold-start rule under ``root``, as ``file:line: why``."""
    out = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            line = getattr(node, "lineno", 0)
            if rel != ENGINE_OWNER:
                if isinstance(node, ast.Compare) and _speed_threshold(node):
                    out.append(f"{rel}:{line}: engine speed against a threshold (use "
                               "vehval.equations.engine_state)")
                if isinstance(node, ast.Assign) and any(
                        isinstance(t, ast.Name) and ENGINE_CONST.match(t.id)
                        for t in node.targets):
                    out.append(f"{rel}:{line}: an engine-on speed constant (use "
                               "vehval.equations.engine_state)")
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    a = node.args
                    args = a.args[len(a.args) - len(a.defaults):] + a.kwonlyargs
                    defaults = list(a.defaults) + list(a.kw_defaults)
                    for arg, d in zip(args, defaults):
                        if "rpm" in arg.arg and isinstance(d, ast.Constant) \
                                and isinstance(d.value, float) and "on" in arg.arg.split("_"):
                            out.append(f"{rel}:{line}: engine-on threshold {d.value!r} as a "
                                       f"default of '{arg.arg}' (use ENGINE_ON_RPM)")
            if rel != COLD_OWNER:
                if isinstance(node, ast.Compare) and any(
                        isinstance(o, (ast.Lt, ast.LtE, ast.Gt, ast.GtE)) for o in node.ops) \
                        and any(n.startswith("COLD_") for n in _names(node)):
                    out.append(f"{rel}:{line}: a cold-start threshold compared (use "
                               "vehval.conditions.cold_start)")
                if isinstance(node, ast.Assign) and isinstance(node.value, ast.Constant) \
                        and any(isinstance(t, ast.Name) and t.id.startswith("COLD_")
                                for t in node.targets):
                    out.append(f"{rel}:{line}: a cold-start threshold written as a number "
                               "(use vehval.conditions)")
    return out


def test_one_engine_on_rule_and_one_cold_start_rule():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_each_kind_of_breach(tmp_path):
    pkg = tmp_path / "vehval"
    (pkg / "equations").mkdir(parents=True)
    (pkg / "equations" / "engine_state.py").write_text("ENGINE_ON_RPM = 400.0\n")
    (pkg / "conditions.py").write_text("COLD_START_BAND_K = 10.0\n")
    (pkg / "bad.py").write_text(
        "RPM = 0.1\nENGINE_STOPPED_RAD_S = 10.0\nCOLD_COOLANT_C = 40.0\n"
        "def on(eng_spd, on_speed_rpm: float = 400.0):\n"
        "    return eng_spd > on_speed_rpm * RPM\n"
        "def cold(c0, cell):\n"
        "    return abs(c0 - cell) <= COLD_START_BAND_K\n")
    text = "\n".join(scan(pkg))
    for why in ("engine speed against a threshold", "engine-on speed constant",
                "threshold 400.0 as a default", "cold-start threshold compared",
                "cold-start threshold written as a number"):
        assert why in text, (why, text)
    assert "engine_state.py" not in text and "conditions.py" not in text


def test_noise_around_one_threshold_is_not_a_start():
    """A running engine whose speed dithers around 400 rpm (sensor noise while spinning
    down) starts once; a single threshold counted every crossing."""
    t = np.arange(0.0, 60.0, 0.1)
    rpm = np.where(t < 10, 0.0, 1000.0)
    rpm[(t >= 30) & (t < 32)] = 400.0 + 30.0 * np.sin(np.arange(20) * 2.5)
    rpm[t >= 40] = 0.0
    on = detect_engine_on(t, rpm * np.pi / 30).on
    assert int(np.sum(np.diff(on.astype(int)) == 1)) == 1
    assert int(np.sum(np.diff((rpm > 400).astype(int)) == 1)) > 1


def test_cold_start_rule():
    assert cold_start(22.0, 23.0)[0] is True          # soaked in its cell
    assert cold_start(-6.0, -7.0)[0] is True          # cold-temperature FTP
    assert cold_start(5.0, 25.0)[0] is True           # brought in cold
    assert cold_start(36.0, 22.0)[0] is False         # a few hours' soak: not cold
    assert cold_start(85.0, 25.0)[0] is False         # hot start
    assert cold_start(39.0, None)[0] is True          # no cell: below the FTP top 30 degC + 10 K
    assert cold_start(40.0, None)[0] is False
    assert cold_start(float("nan"), 25.0)[0] is None
