"""Unit plausibility: a wrong unit in the template is a QA finding naming the likely error.

Reproduces the report: speed declared km/h instead of mph, fuel declared per hour instead
of per second gave 0 warnings. The virtual dyno file (one speed source, as in a D3 file)
is imported with the units swapped in its template.
"""

from __future__ import annotations

import pytest
import yaml

from helpers.data import REAL
from vehval.qa.findings import Kind
from vehval.workflow import TestRun


@pytest.fixture(scope="module")
def dyno_file(tmp_path_factory):
    from vehval.synth import make_virtual_test

    d = tmp_path_factory.mktemp("plaus") / "udds"
    make_virtual_test("prius_2004", "udds", seed=2, faults="none", outdir=d)
    return d


def _qa(d, tmp_path, **units):
    tpl = yaml.safe_load((d / "template.yaml").read_text())
    spec = tpl["files"][0]
    spec["channels"] = {k: v for k, v in spec["channels"].items()}
    for col, unit in units.items():
        spec["channels"][col]["unit"] = unit
    tpl["files"] = [spec]
    tpl.pop("cycle", None)
    path = tmp_path / "template.yaml"
    path.write_text(yaml.safe_dump(tpl))
    run = TestRun.load(sorted(d.glob("*_d3.txt")), path, "prius_2004")
    return [f for f in run.qa().result.findings if f.kind == Kind.UNIT_SUSPECT]


def test_correct_units_give_no_unit_finding(dyno_file, tmp_path):
    assert _qa(dyno_file, tmp_path) == []


def test_speed_in_mph_declared_kmh_is_named(dyno_file, tmp_path):
    found = _qa(dyno_file, tmp_path, Dyno_Speed="km/h")
    speed = [f for f in found if f.signal == "veh_spd_test"]
    assert speed, [f.message for f in found]
    assert "declared km/h; the data say mph" in speed[0].message
    assert speed[0].numbers["factor"] == pytest.approx(1.609344)


def test_fuel_per_hour_declared_for_per_second_is_named(dyno_file, tmp_path):
    found = _qa(dyno_file, tmp_path, Eng_FuelFlow_Direct="l/h")   # data are cm^3/s
    fuel = [f for f in found if f.signal == "fuel_rate_test"]
    assert fuel, [f.message for f in found]
    assert fuel[0].numbers["factor"] == pytest.approx(3.6)
    assert fuel[0].numbers["efficiency"] > 0.5


def test_both_errors_at_once(dyno_file, tmp_path):
    found = _qa(dyno_file, tmp_path, Dyno_Speed="km/h", Eng_FuelFlow_Direct="l/h")
    assert {f.signal for f in found} >= {"veh_spd_test", "fuel_rate_test"}


CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel" / "61410012 Test Data.txt"


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_file(), reason="real data not available")
def test_cruze_with_kmh_and_kg_per_h_declared(tmp_path):
    """The reported case: a Cruze UDDS with speed declared km/h (data mph) and fuel kg/h
    (data g/s) gave 0 warnings; both are now errors naming the unit."""
    src = (__import__("pathlib").Path(__file__).parent / "templates" / "cruze.yaml").read_text()
    bad = src.replace("{name: veh_spd_test, unit: mph}", "{name: veh_spd_test, unit: km/h}")
    bad = bad.replace("{name: fuel_rate_test, unit: g/s}", "{name: fuel_rate_test, unit: kg/h}")
    assert bad.count("km/h") == 1 and bad.count("kg/h") == 1
    (tmp_path / "t.yaml").write_text(bad)
    found = TestRun.load([CRUZE], tmp_path / "t.yaml").qa().result.findings
    msgs = {f.signal: f.message for f in found if f.kind == Kind.UNIT_SUSPECT}
    assert "declared km/h; the data say mph" in msgs["veh_spd_test"]
    # the file header names g/s: the hint gives both units and the factor
    assert "declares kg/h" in msgs["fuel_rate_test"] and "says g/s" in msgs["fuel_rate_test"]
    assert "x3.6" in msgs["fuel_rate_test"]
