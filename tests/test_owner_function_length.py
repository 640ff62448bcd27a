"""No function in the package over 120 lines without a reason written beside it.

A function of more than :data:`LIMIT` lines (``def`` to its last line, docstring included)
fails with the file and line unless its signature carries a ``# long: <reason>`` comment
(a compiled kernel that must stay one loop, for example). The scan reads the sources with
``ast`` (no import).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
LIMIT = 120
REASON = re.compile(r"#\s*long:\s*\S")


def scan(root: Path = PKG, limit: int = LIMIT) -> list[str]:
    """Every function over ``limit`` lines without a reason, as ``file:line: name (n lines)``."""
    out = []
    for path in sorted(root.rglob("*.py")):
        lines = path.read_text(encoding="utf-8").splitlines()
        for node in ast.walk(ast.parse("\n".join(lines))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            n = (node.end_lineno or node.lineno) - node.lineno + 1
            if n <= limit:
                continue
            signature = lines[node.lineno - 1:node.body[0].lineno - 1] or [lines[node.lineno - 1]]
            if not any(REASON.search(s) for s in signature):
                out.append(f"{path.relative_to(root)}:{node.lineno}: {node.name} ({n} lines): "
                           "split it, or write '# long: <reason>' beside its def")
    return out


def test_no_long_function_without_a_reason():
    assert scan() == []


def test_scan_sees_a_long_function_and_accepts_a_reason(tmp_path):
    body = "".join(f"    x{i} = {i}\n" for i in range(130))
    (tmp_path / "a.py").write_text("def long_one():\n" + body, encoding="utf-8")
    (tmp_path / "b.py").write_text("def kernel(a,\n           b):  # long: one compiled loop\n"
                                   + body, encoding="utf-8")
    (tmp_path / "c.py").write_text("def short():\n    return 1\n", encoding="utf-8")
    found = scan(tmp_path)
    assert len(found) == 1 and found[0].startswith("a.py:1: long_one (131 lines)"), found
