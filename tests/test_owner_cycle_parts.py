"""One owner for the phase (bag) boundaries of the regulatory cycles.

The table is ``vehval/data/cycles/parts.yaml``, read through :func:`vehval.cycles.cycle_parts`.
Results, the EPA procedures, the virtual dyno's phase channel and the cycle matcher read it;
no module writes a boundary of it as a number (1369, 1372, 505, 495, 496, 1874 s) or in a
rule text. The table itself is checked against the traces it describes.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from vehval import cycles_match
from vehval.cycles import cycle_parts, cycles_with_parts, load_cycle, part_boundary_s
from vehval.epa import procedures
from vehval.results import composites, phases
from vehval.synth import clean

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
OWNER = PKG / "cycles.py"
#: Boundaries [s] that only the part table may hold (and the historic wrong copies).
BOUNDARIES = (1369.0, 1372.0, 505.0, 495.0, 496.0, 1874.0)
_TEXT = ("1369 s", "1372 s", "505 s", "495 s", "496 s", "-1369", "-505", "-495", "-496",
         "495-", "496-")


def _docstrings(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def scan(root: Path = PKG) -> list[str]:
    """Every boundary written outside the owner under ``root``, as ``file:line: why``."""
    out = []
    for path in sorted(root.rglob("*.py")):
        if path.name == OWNER.name and path.parent == root:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docs = _docstrings(tree)
        rel = path.relative_to(root)
        for node in ast.walk(tree):
            if not isinstance(node, ast.Constant) or id(node) in docs:
                continue
            v = node.value
            if isinstance(v, (int, float)) and not isinstance(v, bool) and float(v) in BOUNDARIES:
                out.append(f"{rel}:{node.lineno}: cycle part boundary {v!r} written in code "
                           "(read vehval.cycles.cycle_parts / part_boundary_s)")
            elif isinstance(v, str) and any(t in v for t in _TEXT):
                out.append(f"{rel}:{node.lineno}: cycle part boundary in a text "
                           "(use vehval.cycles.part_rule)")
    return out


def test_no_second_copy_of_a_phase_boundary():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_a_copy(tmp_path):
    pkg = tmp_path / "vehval"
    pkg.mkdir()
    (pkg / "cycles.py").write_text("X = 1369.0\n")
    (pkg / "bad.py").write_text('"""Bag 2 ends at 1369 s (a docstring may say so)."""\n'
                                "END = 496.0\nB = {'ftp': [505, 1372.0]}\n"
                                "RULE = 'highway part 130-496 s'\n")
    found = scan(pkg)
    assert len(found) == 4, found
    assert not any("cycles.py" in f for f in found)


def test_every_consumer_reads_the_same_table():
    for c in cycles_with_parts():
        assert phases.CYCLE_PARTS[c] == cycle_parts(c)
    assert procedures.UDDS_BAG1_END_S == part_boundary_s("udds", "bag1")
    assert (procedures.US06_CITY_END_S, procedures.US06_HWY_END_S) == (
        part_boundary_s("us06", "city"), part_boundary_s("us06", "highway"))
    us06_bags = {b.name: b.windows for b in procedures.US06.bags}
    assert us06_bags["bag 2 highway part"] == ((130.0, 495.0),)
    assert cycles_match.SPLIT_AT_S["ftp75"] == part_boundary_s("ftp75", "bag2") == 1369.0
    assert "130-495 s" in composites._LAST_RUN_RULES["us06"]
    # the virtual dyno numbers its phase channel over the same parts
    for c in cycles_with_parts():
        parts = cycle_parts(c)
        grid = np.arange(0.0, parts[-1][2] + 1.0)
        ph = clean.test_phase(grid, c, parts[-1][2])
        names = list(dict.fromkeys(p for p, _, _ in parts))
        for p, a, b in parts:
            inside = (grid >= a) & (grid < b)
            assert np.all(ph[inside] == names.index(p) + 1), (c, p)


def test_the_table_matches_the_traces():
    """Parts tile each trace; FTP-75 bag 3 is UDDS bag 1 again from the end of bag 2."""
    for c in cycles_with_parts():
        parts = cycle_parts(c)
        assert parts[0][1] == 0.0 and parts[-1][2] == load_cycle(c).duration_s, c
        assert all(p[2] == q[1] for p, q in zip(parts, parts[1:])), c
    udds, ftp = load_cycle("udds"), load_cycle("ftp75")
    b1, b2 = part_boundary_s("udds", "bag1"), part_boundary_s("ftp75", "bag2")
    assert b2 == udds.duration_s
    t = np.arange(0.0, b1 + 1.0)
    assert np.allclose(ftp.speed_at(b2 + t), udds.speed_at(t))
    us06 = load_cycle("us06")
    # both US06 splits fall inside a stop: the split second moves idle time only
    for s in (part_boundary_s("us06", "city"), part_boundary_s("us06", "highway")):
        assert us06.speed_at(s) == 0.0
