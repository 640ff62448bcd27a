"""One owner for the peak and plausible brake efficiency of an engine map.

``vehval/vehicle/maps.py`` (beside the maps and the best-efficiency line) computes the peak
brake efficiency of a fuel map (:func:`peak_brake_efficiency`,
:func:`peak_brake_efficiency_of_map`), the best efficiency on the operating line
(:func:`best_line_efficiency`) and judges it against the band of road engines
(:func:`brake_efficiency_plausible`); the band's value is written once, in
``vehval.constants.BRAKE_EFFICIENCY_RANGE``. Anywhere else the scan fails on:

* a function computing a peak / best / maximum efficiency;
* a second name for the band (``ETA_PLAUSIBLE = BRAKE_EFFICIENCY_RANGE``) or its figures;
* an engine efficiency written as a number (``eta_eng = 0.35``);
* the band compared by hand (``lo <= eta <= hi`` in a module reading it), except in
  ``qa/fuel_gates.py``, which judges a measured test's work over fuel energy with the band
  widened by the driveline at the wheel (a different quantity from a map's peak).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

from vehval.constants import BRAKE_EFFICIENCY_RANGE
from vehval.vehicle import load_vehicle
from vehval.vehicle.maps import (
    best_line_efficiency,
    brake_efficiency_plausible,
    peak_brake_efficiency,
    peak_brake_efficiency_of_map,
)

PKG = Path(__file__).resolve().parents[1] / "src" / "vehval"
OWNER = Path("vehicle") / "maps.py"
BAND_HOME = Path("constants.py")
MEASURED = Path("qa") / "fuel_gates.py"
FUNC = re.compile(r"(peak|best|max)\w*_eff", re.I)
ENGINE_ETA = re.compile(r"^(eta_eng\w*|\w*engine_eff\w*|\w*brake_eff\w*)$", re.I)


def _targets(node: ast.AST) -> list[ast.AST]:
    if isinstance(node, ast.Assign):
        return list(node.targets)
    if isinstance(node, ast.AnnAssign):
        return [node.target]
    return []


def _name(node: ast.AST) -> str:
    return node.id if isinstance(node, ast.Name) else (
        node.attr if isinstance(node, ast.Attribute) else "")


def scan(root: Path = PKG) -> list[str]:  # noqa: C901 - one branch per rule above
    """Every breach of the module docstring's rules under ``root``, as ``file:line: why``."""
    out = []
    band = tuple(float(x) for x in BRAKE_EFFICIENCY_RANGE)
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel in (OWNER, BAND_HOME):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        # per function, the names bound to the band's ends: lo, hi = BRAKE_EFFICIENCY_RANGE
        ends: dict[int, set[str]] = {}
        for fn in ast.walk(tree):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                names = {e.id for n in ast.walk(fn) if isinstance(n, ast.Assign)
                         and _name(n.value) == "BRAKE_EFFICIENCY_RANGE"
                         for t in n.targets if isinstance(t, ast.Tuple)
                         for e in t.elts if isinstance(e, ast.Name)}
                for n in ast.walk(fn):
                    ends.setdefault(id(n), set()).update(names)
        for node in ast.walk(tree):
            line = getattr(node, "lineno", 0)
            if isinstance(node, ast.FunctionDef) and FUNC.search(node.name):
                out.append(f"{rel}:{line}: '{node.name}' computes a peak efficiency "
                           "(use vehval.vehicle.maps)")
            value = getattr(node, "value", None)
            for t in _targets(node):
                if _name(value) == "BRAKE_EFFICIENCY_RANGE" and isinstance(t, ast.Name):
                    out.append(f"{rel}:{line}: second name '{t.id}' for the efficiency band")
                if ENGINE_ETA.match(_name(t)) and isinstance(value, ast.Constant) \
                        and isinstance(value.value, float):
                    out.append(f"{rel}:{line}: engine efficiency {value.value!r} written as a "
                               "number (use vehval.vehicle.maps)")
            if isinstance(node, ast.Tuple) and len(node.elts) == 2 and all(
                    isinstance(e, ast.Constant) and isinstance(e.value, float)
                    for e in node.elts) and tuple(
                    e.value for e in node.elts) == band:  # type: ignore[attr-defined]
                out.append(f"{rel}:{line}: the efficiency band written again "
                           "(vehval.constants.BRAKE_EFFICIENCY_RANGE)")
            here = ends.get(id(node), set())
            if rel != MEASURED and isinstance(node, ast.Compare) and len(node.ops) == 2 \
                    and _name(node.left) in here and _name(node.comparators[-1]) in here:
                out.append(f"{rel}:{line}: the efficiency band compared by hand "
                           "(use vehval.vehicle.maps.brake_efficiency_plausible)")
    return out


def test_no_second_owner_of_the_brake_efficiency():
    found = scan()
    assert not found, "\n".join(found)


def test_the_scan_sees_each_kind_of_breach(tmp_path):
    pkg = tmp_path / "vehval"
    (pkg / "vehicle").mkdir(parents=True)
    (pkg / "vehicle" / "maps.py").write_text("def peak_brake_efficiency(e):\n    return 0.4\n")
    (pkg / "bad.py").write_text(
        "from vehval.constants import BRAKE_EFFICIENCY_RANGE\n"
        "ETA_PLAUSIBLE = BRAKE_EFFICIENCY_RANGE\n"
        "BAND = (0.20, 0.45)\n"
        "def peak_efficiency(engine):\n"
        "    eta_eng = 0.35\n"
        "    lo, hi = BRAKE_EFFICIENCY_RANGE\n"
        "    return lo <= eta_eng <= hi\n")
    text = "\n".join(scan(pkg))
    for why in ("'peak_efficiency' computes", "second name 'ETA_PLAUSIBLE'",
                "engine efficiency 0.35", "band written again", "band compared by hand"):
        assert why in text, (why, text)
    assert "maps.py" not in text


def test_the_owner_on_a_real_map():
    """The 2004 Prius engine peaks near 37 % (DESIGN.md) from idle up; its best line
    reaches no more than the grid peak plus the interpolation, and is plausible."""
    e = load_vehicle("prius_2004").engine
    eta, rpm, nm = peak_brake_efficiency(e)
    assert 0.35 < eta < 0.39 and rpm >= e.idle_speed_rpm and nm > 0
    assert brake_efficiency_plausible(eta) and not brake_efficiency_plausible(float("nan"))
    line = best_line_efficiency(e)
    assert brake_efficiency_plausible(line) and line <= eta * 1.02
    below_idle = peak_brake_efficiency_of_map(e.speed_rpm, e.torque_nm, e.fuel_rate_g_per_s,
                                              e.max_torque_nm, e.fuel_lhv_j_per_kg)
    assert below_idle[0] >= eta
    assert np.isnan(peak_brake_efficiency_of_map([1000.0], [10.0], [[0.0]], [50.0], 4e7)[0])


def test_soc_correction_without_engine_use_counts_on_the_best_line():
    """With no engine work the charge correction used a literal 35 %, not the engine's."""
    from vehval.sim import simulate as sim

    veh = load_vehicle("prius_2004")
    ys = np.zeros(len(sim.SUMMARY))
    idx = {k: i for i, k in enumerate(sim.SUMMARY)}
    ys[idx["distance_m"]] = 1000.0
    ys[idx["ess_chem_energy_j"]] = 1.0e6
    ys[idx["duration_s"]] = 100.0
    s = sim.summarise(veh, ys, 0.6)
    want = best_line_efficiency(veh.engine, veh.best_line)
    assert s["engine_mean_efficiency"] == pytest.approx(want, rel=1e-12)
