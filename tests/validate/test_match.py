"""The vehicle model against the test: a mismatch is said, not hidden in "fuel 30 % FAIL"."""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers.data import REAL
from vehval.cli.commands_validate import _cycle, _pct
from vehval.test import Signal, Test, TestMeta
from vehval.validate.match import vehicle_match
from vehval.vehicle import load_vehicle

from .helpers import hand_test

CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel" / "61410007 Test Data.txt"


def _diesel_conventional() -> Test:
    test = Test(meta=TestMeta(test_id="cruze", constants={
        "test_mass_kg": 1727.3, "fuel_density_kg_per_m3": 851.0}))
    test.add(Signal.standard("veh_spd_test", [0.0, 1.0, 2.0], [0.0, 1.0, 2.0], source="dyno"))
    test.add(Signal.standard("fuel_rate_test", [0.0, 1.0, 2.0], [1e-4] * 3, source="dyno"))
    return test


def test_diesel_conventional_test_does_not_match_the_prius():
    m = vehicle_match(_diesel_conventional(), load_vehicle("prius_2004"))
    assert not m.matches and len(m.problems) == 3
    text = m.message()
    assert "hybrid but the test has no battery" in text
    assert "851 kg/m³ in the test (diesel), 740 in the vehicle (gasoline)" in text
    assert "test mass 1727.3 kg, vehicle 1295 kg (+33 %)" in text


def test_a_hybrid_test_matches_the_prius():
    assert vehicle_match(hand_test(), load_vehicle("prius_2004")).matches


def test_terminal_never_prints_nan_or_an_empty_cycle():
    assert _pct(float("nan"), 2) == "n/a" and _pct(None, 1) == "n/a"
    assert _pct(5.849, 2) == "5.85 %"
    assert _cycle("", "other") == "no cycle identified"
    assert _cycle("udds", "high_transient") == "udds, high_transient"


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_file(), reason="real data not available")
def test_cli_says_the_vehicle_does_not_match(tmp_path, capsys):
    from vehval.cli import main

    tpl = Path(__file__).resolve().parents[1] / "qa" / "templates" / "cruze.yaml"
    assert main(["validate", str(CRUZE), "-t", str(tpl), "-o", str(tmp_path / "v"), "--dt", "1"]) == 0
    out, err = capsys.readouterr()
    assert "vehicle prius_2004 does not match test 61410007" in err
    assert "nan" not in out and "(, other)" not in out
    assert "(no cycle identified): fuel n/a" in out


def test_analysis_of_a_conventional_car_prints_no_hybrid_rule(tmp_path, capsys):
    """Reported: a conventional car's analysis printed "rule agreement 99.4 %" and on/off bounds."""
    import numpy as np

    from vehval.cli import main

    t = np.arange(0.0, 300.0, 0.1)
    v = np.clip(10 * np.sin(t / 30.0), 0, None) * 1.0
    data = tmp_path / "conv.csv"
    lines = ["time,speed,rpm,fuel"] + [f"{a:.1f},{b:.4f},{800 + 200 * b:.1f},{0.3 + 0.1 * b:.4f}"
                                       for a, b in zip(t, v)]
    data.write_text("\n".join(lines) + "\n")
    tpl = tmp_path / "t.yaml"
    tpl.write_text("template_version: 1\nfiles:\n  - source: dyno\n    format: csv\n"
                   "    time: {column: time, unit: s}\n    channels:\n"
                   "      speed: {name: veh_spd_test, unit: m/s}\n"
                   "      rpm: {name: eng_spd_out_test, unit: rpm}\n"
                   "      fuel: {name: fuel_rate_test, unit: g/s}\n")
    assert main(["analyze", str(data), "-t", str(tpl), "-o", str(tmp_path / "a")]) == 0
    out = capsys.readouterr().out
    assert "conventional vehicle" in out and "rule agreement" not in out and "bound" not in out
    assert (tmp_path / "a" / "control.json").is_file()


def test_cli_validate_says_why_a_test_fails(tmp_path, capsys):
    """A FAIL on screen carries its reason: a log without a fuel channel (the Prius c OBD logs)
    printed 'fuel n/a, ...: FAIL' and nothing else."""
    from vehval.cli import main
    from vehval.synth import make_virtual_test

    vt = make_virtual_test(cycle="japan1015", seed=2, faults="none", outdir=tmp_path / "vt")
    tpl = vt.template_path.read_text(encoding="utf-8")
    no_fuel = tpl.replace("{name: fuel_rate_test, unit: ccps}",
                          "{delete: true, reason: not logged}")
    assert no_fuel != tpl
    vt.template_path.write_text(no_fuel, encoding="utf-8")
    assert main(["validate", *map(str, vt.files), "-t", str(vt.template_path), "--vehicle",
                 "prius_2004", "-o", str(tmp_path / "v"), "--dt", "1"]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "FAIL" in ln)
    assert "fuel n/a" in line and line.endswith("FAIL: fuel_pct: cannot be computed (missing signal)")
