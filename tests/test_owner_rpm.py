"""One owner for the rpm conversion: ``vehval.constants.RPM_RAD_PER_S`` (and ``display``).

A conversion between rad/s and rpm written by hand (``30 / np.pi``, ``60 / (2 * np.pi)``,
``n * math.pi / 30``, ``2 * np.pi / 60``, or a rounded 9.549 / 0.1047) anywhere but
``constants.py`` fails with the file and line. The scan reads the package with ``ast``: a
chain of ``*`` and ``/`` that holds pi and 30 or 60 is a conversion.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

from vehval import display
from vehval.constants import RPM_RAD_PER_S

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
OWNER = Path("constants.py")
ROUNDED = (30 / math.pi, math.pi / 30)


def _leaves(node: ast.AST) -> list[ast.AST]:
    """Operands of a chain of ``*`` and ``/`` (not through ``+``, ``-`` or calls)."""
    if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
        return _leaves(node.left) + _leaves(node.right)
    return [node]


def _is_pi(node: ast.AST) -> bool:
    """``np.pi``, ``math.pi``, ``pi`` or pi written as a number (3.14159...)."""
    return (isinstance(node, ast.Attribute) and node.attr == "pi") or (
        isinstance(node, ast.Name) and node.id == "pi") or (
        isinstance(node, ast.Constant) and isinstance(node.value, float)
        and abs(node.value - math.pi) < 1e-4)


def scan(root: Path = PKG) -> list[str]:
    """Every rpm conversion written by hand under ``root``, as ``file:line: why``."""
    out: set[str] = set()
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel == OWNER:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
                leaves = _leaves(node)
                nums = {float(x.value) for x in leaves if isinstance(x, ast.Constant)
                        and isinstance(x.value, (int, float)) and not isinstance(x.value, bool)}
                if any(_is_pi(x) for x in leaves) and nums & {30.0, 60.0}:
                    out.add(f"{rel}:{node.lineno}: rpm conversion by hand "
                            "(use vehval.constants.RPM_RAD_PER_S or vehval.display)")
            elif isinstance(node, ast.Constant) and isinstance(node.value, float) \
                    and any(abs(node.value - r) < 2e-3 * r for r in ROUNDED):
                out.add(f"{rel}:{node.lineno}: rounded rpm factor {node.value!r} "
                        "(use vehval.constants.RPM_RAD_PER_S)")
    return sorted(out)


def test_no_rpm_conversion_by_hand():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_each_spelling(tmp_path):
    pkg = tmp_path / "vehval"
    pkg.mkdir()
    (pkg / "constants.py").write_text("import math\nRPM_RAD_PER_S = math.pi / 30.0\n")
    (pkg / "bad.py").write_text(
        "import math\nimport numpy as np\n"
        "A = 30.0 / np.pi\n"
        "def f(w, n):\n"
        "    b = w * 60 / (2 * np.pi)\n"
        "    c = n * math.pi / 30\n"
        "    d = 2.0 * np.pi / 60.0\n"
        "    e = w * 9.5493\n"
        "    ok = 2 * np.pi * w / 7.0 + 30\n"
        "    f = w * 30 / 3.141592653589793\n"
        "    return b, c, d, e, ok, f\n")
    found = scan(pkg)
    assert [f.split(":")[1] for f in found] == ["10", "3", "5", "6", "7", "8"], found
    assert not any("constants.py" in f for f in found)


def test_display_uses_the_constant():
    assert math.isclose(display.TABLE["rad/s"]["us"].convert(RPM_RAD_PER_S), 1.0)
