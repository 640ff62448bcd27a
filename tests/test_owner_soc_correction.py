"""Two SOC corrections under two names, each with one owner.

* the simulator's **energy-balance correction**, :func:`vehval.sim.simulate.energy_balance_fuel_kg`
  (net battery energy to fuel through the run's engine and path efficiencies);
* the results stage's **SAE J1711 NEC correction**, :mod:`vehval.results.soc` (1 % tolerance,
  stated factor or regression over tests).

The scan fails on a battery energy turned into fuel by hand (``x / (lhv * eta * ...)``)
outside the first owner, a J1711 NEC tolerance written outside the second, and text that
calls the simulator's method J1711's ("J1711 energy method").
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from vehval.results.soc import NEC_TOLERANCE, soc_correction
from vehval.sim.simulate import energy_balance_fuel_kg

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
SIM_OWNER = Path("sim") / "simulate.py"
J1711_OWNER = Path("results") / "soc.py"
LHV = re.compile(r"lhv", re.I)
EFF = re.compile(r"(eta|eff)", re.I)
BATTERY = re.compile(r"(^d_?e$|batt|ess_|nec|chem)", re.I)
MIXED = re.compile(r"J1711[\w\s(),-]{0,12}energy method|energy method of SAE J1711", re.I)


def _chain(node: ast.AST) -> list[str]:
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult):
        return _chain(node.left) + _chain(node.right)
    if isinstance(node, ast.Name):
        return [node.id]
    if isinstance(node, ast.Attribute):
        return [node.attr]
    return []


def scan(root: Path = PKG) -> list[str]:
    """Every breach of the module docstring's rules under ``root``, as ``file:line: why``."""
    out = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            line = getattr(node, "lineno", 0)
            if rel != SIM_OWNER and isinstance(node, ast.BinOp) \
                    and isinstance(node.op, ast.Div):
                names = _chain(node.right)
                num = {n.id if isinstance(n, ast.Name) else getattr(n, "attr", "")
                       for n in ast.walk(node.left)}
                if any(LHV.search(n) for n in names) and any(EFF.search(n) for n in names) \
                        and any(BATTERY.search(n) for n in num if n):
                    out.append(f"{rel}:{line}: battery energy turned into fuel by hand (use "
                               "vehval.sim.simulate.energy_balance_fuel_kg)")
            if rel != J1711_OWNER and isinstance(node, ast.Assign) and any(
                    isinstance(t, ast.Name) and "NEC" in t.id for t in node.targets) \
                    and isinstance(node.value, ast.Constant):
                out.append(f"{rel}:{line}: a J1711 NEC threshold outside vehval.results.soc")
            if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and MIXED.search(node.value):
                out.append(f"{rel}:{line}: the simulator's energy-balance correction called "
                           "J1711's (two methods, two names)")
    return out


def test_two_corrections_two_names_one_owner_each():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_each_kind_of_breach(tmp_path):
    pkg = tmp_path / "vehval"
    pkg.mkdir()
    (pkg / "bad.py").write_text(
        '"""SOC-corrected fuel (SAE J1711 energy method)."""\n'
        "NEC_LIMIT = 0.01\n"
        "def f(m, de, lhv, eta_eng, c):\n"
        "    return m + de / (lhv * eta_eng * c.path)\n")
    text = "\n".join(scan(pkg))
    for why in ("by hand", "J1711 NEC threshold", "called J1711's"):
        assert why in text, (why, text)


def test_the_two_methods_differ_on_a_small_imbalance():
    """0.5 % of the fuel energy taken from the battery: J1711 leaves the result as it is,
    the energy balance charges the fuel it would have cost."""
    fuel_kg, lhv = 0.5, 43e6
    nec = 0.005 * fuel_kg * lhv
    assert 0.005 < NEC_TOLERANCE
    j = soc_correction({"test": {"ess_energy_net_j": nec, "fuel_energy_j": fuel_kg * lhv,
                                 "fuel_mass_kg": fuel_kg, "distance_m": 1e4,
                                 "fuel_economy_mpg": 40.0}}, ["test"], battery=True)
    assert j["status"] == "within_tolerance"
    corrected = energy_balance_fuel_kg(fuel_kg, nec, lhv, 0.35, 0.9)
    assert corrected == pytest.approx(fuel_kg + nec / (lhv * 0.35 * 0.9), rel=1e-12)
    assert corrected > fuel_kg * 1.01
