"""One owner for each fuel quantity: the source is scanned so that a second one cannot creep in.

* fuel properties (density, lower heating value, carbon mass fraction) live in the fuel table
  ``data/fuels.yaml`` only: no module writes one of its figures (or a historic default such as
  745 kg/m3 or 42.6 MJ/kg) as a number;
* a fuel volume, an mpg or an L/100 km figure is computed in ``vehval/fuels/quantities.py``
  only: the gallon and litre factors, the unit factors of fuel economy (235.21, 0.264172...)
  and arithmetic assigned to an ``*mpg*`` / ``*per_100km*`` name, or a division by a fuel
  density, anywhere else fail the test with the file and line.

The scan reads the package with ``ast`` (no import), so it also sees code that no test runs.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import yaml

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "vehval"
OWNER = PKG / "fuels" / "quantities.py"
#: Where a unit factor may be defined: the constants module (the mile is a length).
UNIT_HOMES = {PKG / "constants.py", OWNER}

#: Conversion factors of fuel volume / economy and their usual spellings [-].
FACTORS = (3.785411784, 3.785411784e-3, 3.785, 3.7854, 1.609344, 1609.344, 235.21, 235.214,
           235.2145, 0.264172, 0.2641720524, 0.621371, 0.62137119, 2.352145, 4.54609, 282.48)
#: Fuel properties written in code before the fuel table owned them (and their variants).
HISTORIC = (745.0, 743.0, 740.0, 749.0, 851.0, 42.6e6, 42.9e6, 42.8e6, 43.0e6, 41.5e6, 42.6e3,
            4.26e7)
NAME_QTY = re.compile(r"mpg|per_100\s*km|l_per_100km|per_gal", re.I)
DENSITY = re.compile(r"^(rho|rho_\w+|\w*density\w*|_?m3_per_kg)$", re.I)


def _table_values() -> set[float]:
    data = yaml.safe_load((PKG / "data" / "fuels.yaml").read_text(encoding="utf-8"))
    return {float(p["value"]) for f in data["fuels"].values() for p in f.values()
            if isinstance(p, dict) and "value" in p}


def _close(x: float, refs) -> bool:
    return any(abs(x - r) <= 1e-9 * max(abs(r), 1.0) for r in refs)


def _name(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.Subscript):
        return _name(node.slice)
    return ""


def _arith(node: ast.AST | None) -> bool:
    """An expression that computes (a * or / at any depth, not a plain read or a call)."""
    if node is None:
        return False
    return any(isinstance(n, ast.BinOp) and isinstance(n.op, (ast.Div, ast.Mult))
               for n in ast.walk(node))


def scan(root: Path = PKG) -> list[str]:  # noqa: C901 - one branch per rule of the module docstring
    """Every breach of the module docstring's rules under ``root``, as ``file:line: why``."""
    props = _table_values() | set(HISTORIC)
    owner_rel = OWNER.relative_to(PKG)
    out: list[str] = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        is_owner = rel == owner_rel
        is_unit_home = is_owner or rel in {p.relative_to(PKG) for p in UNIT_HOMES}
        tree = ast.parse(path.read_text(encoding="utf-8"))
        where = f"{rel}"
        for node in ast.walk(tree):
            line = getattr(node, "lineno", 0)
            if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) \
                    and not isinstance(node.value, bool):
                v = float(node.value)
                if not is_unit_home and _close(v, FACTORS):
                    out.append(f"{where}:{line}: fuel-economy unit factor {node.value!r} "
                               "(use vehval.fuels.quantities)")
                if v not in (0.0, 1.0) and _close(v, props) and isinstance(node.value, float):
                    out.append(f"{where}:{line}: fuel property {node.value!r} written in code "
                               "(name a fuel of the fuel table, vehval/data/fuels.yaml)")
            if is_owner:
                continue
            if isinstance(node, (ast.Name, ast.Attribute)) and _name(node) in (
                    "GALLON_US_M3", "LITRE_M3", "CO2_PER_C") and not (
                    rel.parts[0] == "fuels" and rel.name == "__init__.py"):
                out.append(f"{where}:{line}: {_name(node)} used outside vehval.fuels.quantities")
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div) \
                    and DENSITY.match(_name(node.right) or "-"):
                out.append(f"{where}:{line}: fuel volume (a division by the fuel density "
                           f"'{_name(node.right)}'): use vehval.fuels.fuel_volume_m3")
            targets: list[tuple[str, ast.AST | None]] = []
            if isinstance(node, ast.Assign):
                targets = [(_name(t), node.value) for t in node.targets]
            elif isinstance(node, (ast.AnnAssign, ast.AugAssign)):
                targets = [(_name(node.target), node.value)]
            elif isinstance(node, ast.Dict):
                targets = [(_name(k), v) for k, v in zip(node.keys, node.values) if k is not None]
            elif isinstance(node, ast.keyword) and node.arg:
                targets = [(node.arg, node.value)]
            elif isinstance(node, ast.FunctionDef) and NAME_QTY.search(node.name):
                targets = [(node.name, r.value) for r in ast.walk(node)
                           if isinstance(r, ast.Return)]
            for name, value in targets:
                if NAME_QTY.search(name or "") and _arith(value):
                    out.append(f"{where}:{line}: '{name}' computed by hand: use "
                               "vehval.fuels.quantities")
    return out


def test_no_second_owner_of_a_fuel_quantity():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_each_kind_of_breach(tmp_path):
    """Each rule fires on a module that breaks it (the scan is not vacuous)."""
    pkg = tmp_path / "vehval"
    (pkg / "fuels").mkdir(parents=True)
    (pkg / "fuels" / "quantities.py").write_text("GALLON_US_M3 = 3.785411784e-3\n")
    (pkg / "bad.py").write_text(
        "DENSITY = 745.0\n"
        "LHV = 42.6e6\n"
        "def f(dist, fuel, rho):\n"
        "    gal = fuel / rho / 3.785411784e-3\n"
        "    out = {'fuel_economy_mpg': dist / 1609.344 / gal}\n"
        "    l_per_100km = 235.21 / out['fuel_economy_mpg']\n"
        "    return out, l_per_100km\n")
    found = scan(pkg)
    text = "\n".join(found)
    for why in ("fuel property 745.0", "fuel property 42600000.0", "unit factor 0.003785411784",
                "unit factor 1609.344", "unit factor 235.21", "division by the fuel density",
                "'fuel_economy_mpg' computed by hand", "'l_per_100km' computed by hand"):
        assert why in text, (why, found)
    assert not any("quantities.py" in f for f in found)
