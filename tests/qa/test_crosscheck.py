"""Physical cross-checks: each names the declared unit, the probable one and the factor.

Hand-computed expectations on small synthetic signals (the factor between two units is the
ratio of their SI scales: mg/s -> g/s is x1000, rad/s -> rpm x0.1047), then the reported
Cruze cases on the real file (skipped when the shared data are absent).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from helpers.data import REAL
from vehval.io.importer import _did_you_mean
from vehval.qa import crosscheck as cc
from vehval.qa.findings import Kind, Severity
from vehval.qa.unit_hints import probable_units
from vehval.test import Signal, Test
from vehval.test import TestMeta as Meta
from vehval.units import conversion

T = np.arange(0.0, 1200.0, 1.0)


def _sig(name: str, raw_values: np.ndarray, raw_unit: str, si_unit: str, *, time=T,
         notes: list[str] | None = None, density: float | None = None) -> Signal:
    scale, off = conversion(raw_unit, si_unit, fuel_density_kg_per_m3=density)
    return Signal(name=name, time=time, values=np.asarray(raw_values) * scale + off,
                  unit=si_unit, raw_name=name.upper(), raw_unit=raw_unit, notes=notes or [])


def _test(*signals: Signal) -> Test:
    test = Test(meta=Meta(test_id="x"))
    for s in signals:
        test.add(s)
    return test


def test_mg_per_s_declared_for_g_per_s_is_named_with_x1000():
    """Efficiency 20 % as g/s: declared mg/s gives 20,000 %: hint g/s, factor 1000."""
    fuel = _sig("fuel_rate_test", np.full(T.size, 1.0), "mg/s", "kg/s")  # data: 1 g/s
    e_fuel_true = 1e-3 * 1199.0 * 43e6                                    # [J]
    wheel = 0.2 * e_fuel_true

    def eff(vals: np.ndarray) -> float:
        return wheel / (float(np.trapezoid(vals, T)) * 43e6)
    hints = probable_units(fuel, eff, cc.EFFICIENCY_BAND)
    assert hints[0].unit == "g/s"
    assert hints[0].factor == pytest.approx(1000.0)
    assert hints[0].value == pytest.approx(0.2)


def _drive(mass: float, a_amp: float = 1.0):
    t = np.arange(0.0, 600.0, 0.1)
    v = 12.0 + 10.0 * np.sin(t / 10.0) * a_amp              # a = cos(t/10) [m/s^2]
    a = np.cos(t / 10.0) * a_amp
    f = mass * a + 100.0 + 12.0 * v + 0.4 * v * v             # [N]
    return t, v, f


def test_mass_gain_is_one_for_a_consistent_force_and_mass():
    t, v, f = _drive(1500.0)
    assert cc.mass_gain(f, t, v, 1500.0) == pytest.approx(1.0, rel=0.02)  # 1 s smoothing


def _force_test(mass_kg: float, force_unit: str = "N"):
    t, v, f = _drive(1500.0)
    scale = conversion(force_unit, "N")[0]
    spd = Signal.standard("veh_spd_test", t, v, raw_unit="m/s", raw_name="SPD")
    frc = Signal.standard("veh_frc_in_test", t, f / 4.4482216152605 if force_unit == "N"
                          else f, raw_unit="N", raw_name="FRC")
    if force_unit == "lbf":             # data in lbf, declared N
        frc = Signal.standard("veh_frc_in_test", t, f / scale, raw_unit="N", raw_name="FRC")
    else:
        frc = Signal.standard("veh_frc_in_test", t, f, raw_unit="N", raw_name="FRC")
    return cc.force_mass_check(_test(spd, frc), {"test_mass_kg": mass_kg}, cc._Verdicts())


def test_test_mass_in_lb_is_named():
    found = _force_test(1500.0 / cc.LB_KG)
    assert len(found) == 1 and found[0].severity == Severity.ERROR
    assert found[0].numbers["gain"] == pytest.approx(cc.LB_KG, rel=0.03)
    assert "probably in lb" in found[0].message
    assert "set test_mass_kg to 1500" in found[0].fix


def test_force_in_lbf_declared_n_is_named():
    found = _force_test(1500.0, "lbf")
    assert len(found) == 1
    assert found[0].numbers["probable_unit"] == "lbf"
    assert found[0].numbers["factor"] == pytest.approx(4.4482216, rel=1e-6)
    assert "in lbf, not N (x4.448)" in found[0].fix


def test_consistent_force_gives_nothing():
    assert _force_test(1500.0) == []


def test_rpm_declared_rad_per_s():
    rpm = 800.0 + 1200.0 * np.abs(np.sin(T / 50.0))
    found = cc.engine_speed_check(_test(_sig("eng_spd_out_test", rpm, "rad/s", "rad/s")),
                                  cc._Verdicts())
    assert len(found) == 1 and found[0].kind == Kind.UNIT_SUSPECT
    assert found[0].numbers["probable_unit"] == "rpm"
    assert found[0].numbers["factor"] == pytest.approx(math.pi / 30)
    assert "in rpm, not rad/s (x0.1047)" in found[0].fix


@pytest.mark.parametrize("data_unit,declared,expect", [
    ("degF", "degC", "degF"),      # 73.4 degF read as degC: a 73 degC cell
    ("degC", "K", "degC"),         # 23 degC read as K: -250 degC
])
def test_ambient_temperature_units(data_unit, declared, expect):
    raw = np.full(T.size, 23.0 if data_unit == "degC" else 73.4)
    found = cc.temperature_check(_test(_sig("amb_temp_test", raw, declared, "degC")),
                                 cc._Verdicts())
    assert len(found) == 1, found
    assert found[0].numbers["probable_unit"] == expect


def test_pressure_kpa_declared_pa():
    found = cc.pressure_check(_test(_sig("amb_pres_test", np.full(T.size, 99.0), "Pa", "Pa")),
                              cc._Verdicts())
    assert len(found) == 1
    assert found[0].numbers["probable_unit"] == "kPa"
    assert "in kPa, not Pa (x1000)" in found[0].fix


def test_header_unit_preferred_and_conflict_named():
    """ccps data declared g/s (x0.74 with gasoline) passes every physical band; the file
    header says ccps: an error on the fuel rate naming the header's unit."""
    note = "template unit 'g/s' used instead of header unit 'ccps'"
    fuel = _sig("fuel_rate_test", np.full(T.size, 1.0), "g/s", "kg/s", notes=[note])
    found = cc.header_conflict_check(_test(fuel), cc._Verdicts(), 740.0)
    assert len(found) == 1 and found[0].severity == Severity.ERROR
    assert found[0].numbers["factor"] == pytest.approx(0.74)
    assert "in ccps, as its header says, not g/s (x0.74)" in found[0].fix


def test_phase_channel_that_is_no_counter():
    rh = Signal.standard("test_phase_test", T, 40.0 + np.sin(T / 7.0), raw_name="Test_Cell_RH")
    found = cc.phase_channel_check(_test(rh))
    assert len(found) == 1 and "Test_Cell_RH" in found[0].fix
    ok = Signal.standard("test_phase_test", T, (T > 500).astype(float) + 1, raw_name="Phase_#")
    assert cc.phase_channel_check(_test(ok)) == []


def test_did_you_mean_for_a_misspelled_raw_channel():
    cols = ["Dyno_Speed", "Fuel_Flow_Bench_Modal", "Engine_Speed"]
    assert "did you mean 'Fuel_Flow_Bench_Modal'?" in _did_you_mean("Fuel_Flow_Bench_Modla", cols)
    assert _did_you_mean("Something_Else", cols) == "Something_Else"


CRUZE = REAL / "d3_2014_chevrolet_cruze_diesel" / "61410012 Test Data.txt"
CRUZE_TPL = Path(__file__).parent / "templates" / "cruze.yaml"


def _cruze(tmp_path, edit):
    from vehval.workflow import TestRun

    tpl = yaml.safe_load(CRUZE_TPL.read_text(encoding="utf-8"))
    edit(tpl)
    (tmp_path / "t.yaml").write_text(yaml.safe_dump(tpl), encoding="utf-8")
    return TestRun.load([CRUZE], tmp_path / "t.yaml").qa().result


def _set(channel: str, unit: str):
    def edit(tpl):
        tpl["files"][0]["channels"][channel]["unit"] = unit
    return edit


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_file(), reason="real D3 Cruze data not available")
@pytest.mark.parametrize("edit,signal,fix", [
    (_set("Fuel_Flow_Bench_Modal", "mg/s"), "fuel_rate_test", "in g/s, not mg/s (x1000)"),
    (_set("Dyno_Speed", "km/h"), "veh_spd_test", "in mph, not km/h (x1.609)"),
    (_set("Engine_Speed", "rad/s"), "eng_spd_out_test", "in rpm, not rad/s (x0.1047)"),
    (lambda t: t["constants"].update(test_mass_kg=3808), "veh_frc_in_test",
     "set test_mass_kg to 1727"),
])
def test_cruze_reported_cases(tmp_path, edit, signal, fix):
    res = _cruze(tmp_path, edit)
    hits = [f for f in res.findings if f.kind == Kind.UNIT_SUSPECT and f.signal == signal]
    assert hits and hits[0].severity == Severity.ERROR, [f.message for f in res.findings][:5]
    assert fix in hits[0].fix


@pytest.mark.realdata
@pytest.mark.skipif(not CRUZE.is_file(), reason="real D3 Cruze data not available")
def test_cruze_as_published_has_no_unit_finding(tmp_path):
    res = _cruze(tmp_path, lambda t: None)
    assert [f.message for f in res.findings if f.kind == Kind.UNIT_SUSPECT] == []


def _obd_speed(raw: np.ndarray, unit: str, source: str = "obd") -> Test:
    s = _sig("veh_spd_obd_test", raw, unit, "m/s")
    s.source = source
    return _test(s)


def _road_kmh(n: int = T.size) -> np.ndarray:
    """Whole km/h of an on-road drive (what SAE J1979 PID 0x0D gives)."""
    t = np.arange(n, dtype=float)
    return np.round(np.clip(45.0 + 40.0 * np.sin(t / 60.0), 0.0, None))


@pytest.mark.parametrize("unit, factor", [("mph", 1 / 1.609344), ("m/s", 1 / 3.6)])
def test_whole_numbered_obd_speed_declared_mph_or_mps_is_the_pids_kmh(unit, factor):
    from vehval.qa.obd_checks import obd_speed_unit_check

    out = obd_speed_unit_check(_obd_speed(_road_kmh(), unit), set())
    assert len(out) == 1
    f = out[0]
    assert f.kind == Kind.UNIT_SUSPECT and f.severity == Severity.ERROR
    assert f.numbers["probable_unit"] == "km/h" and f.numbers["declared_unit"] == unit
    assert f.numbers["factor"] == pytest.approx(factor, rel=1e-6)
    assert "J1979" in f.message and f.fix.startswith("declare VEH_SPD_OBD_TEST (veh_spd_obd_test) in km/h")


def test_obd_speed_in_kmh_fractional_mph_dyno_source_or_vouched_speed_raise_nothing():
    from vehval.qa.obd_checks import obd_speed_unit_check

    kmh = _road_kmh()
    assert obd_speed_unit_check(_obd_speed(kmh, "km/h"), set()) == []
    # a logger that converts to mph writes fractions: nothing to say
    assert obd_speed_unit_check(_obd_speed(kmh / 1.609344, "mph"), set()) == []
    # a dyno's whole-numbered speed is not the OBD PID
    assert obd_speed_unit_check(_obd_speed(kmh, "mph", source="dyno"), set()) == []
    # a speed another check found right as declared (it follows its cycle) is not questioned
    assert obd_speed_unit_check(_obd_speed(kmh, "mph"), {"veh_spd_obd_test"}) == []
    # a log too short or too flat to say anything
    assert obd_speed_unit_check(_obd_speed(np.full(T.size, 50.0), "mph"), set()) == []
