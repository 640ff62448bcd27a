"""The QA gate of the results: figures computed from signals with QA errors are withheld."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vehval.qa.findings import Finding, Kind, Severity
from vehval.results import compute_results
from vehval.results.gate import EXIT_WITHHELD, apply_gate, dependencies, headline

from .helpers import make_test, true_signals

EXPLICIT = {"density_kg_per_m3": 800.0, "lhv_j_per_kg": 42e6, "carbon_mass_fraction": 0.86}


def _err(signal: str, kind: Kind = Kind.RANGE, span=(600.0, 700.0), sev=Severity.ERROR,
         fix: str = "") -> Finding:
    return Finding(signal=signal, kind=kind, start_s=span[0], end_s=span[1], severity=sev,
                   message=f"{signal} is wrong here", fix=fix)


def _res():
    t, s = true_signals()
    return compute_results(make_test(t, s), fuel=EXPLICIT)


def test_results_know_the_signals_they_were_computed_from():
    res = _res()
    assert res.inputs == {"speed": ["veh_spd_test"], "fuel": ["fuel_rate_test"],
                          "phase": ["test_phase_test"]}
    dep = dependencies(res.inputs, "phase")
    assert dep["fuel_economy_mpg"] == ["fuel_rate_test", "test_phase_test", "veh_spd_test"]
    assert dep["distance_m"] == ["test_phase_test", "veh_spd_test"]
    # the whole test does not depend on the phase channel
    assert dependencies(res.inputs, "test")["fuel_mass_kg"] == ["fuel_rate_test"]


def test_fuel_error_in_bag2_withholds_the_figures_that_use_bag2_only():
    res = _res()
    bag1_mpg = res.value("bag1", "fuel_economy_mpg")
    apply_gate(res, [_err("fuel_rate_test", fix="declare fuel_rate_test in g/s, not mg/s")])
    # bag 2 spans 505-1369 s: withheld; bag 1 (0-505 s) does not overlap the finding
    assert res.value("bag1", "fuel_economy_mpg") == bag1_mpg and "bag1" not in res.withheld
    for scope in ("bag2", "test", "udds", "ftp75_from_udds"):
        assert res.value(scope, "fuel_economy_mpg") is None, scope
        assert "fuel_economy_mpg" not in res.uncertainty.get(scope, {})
        w = res.withheld[scope]
        assert w["signals"] == ["fuel_rate_test"] and "fuel_economy_mpg" in w["quantities"]
        assert w["fix"] == "declare fuel_rate_test in g/s, not mg/s"
        assert "forced" not in w
    # distance depends on the speed only: still stated
    assert res.value("bag2", "distance_m") is not None
    assert "distance_m" not in res.withheld["bag2"]["quantities"]
    doc = res.to_dict()
    assert doc["withheld_count"] == 4 and doc["forced"] is False
    assert doc["phases"][0]["withheld"] is None
    assert doc["phases"][1]["withheld"]["findings"][0] == {
        "signal": "fuel_rate_test", "kind": "range", "severity": "error",
        "message": "fuel_rate_test is wrong here"}
    assert doc["headline"]["name"] == "udds" and doc["headline"]["fuel_economy_mpg"] is None
    assert doc["headline"]["withheld"]["signals"] == ["fuel_rate_test"]
    json.dumps(doc)  # plain JSON


def test_speed_error_withholds_distance_and_economy_with_a_generic_fix():
    res = _res()
    apply_gate(res, [_err("veh_spd_test", span=(100.0, 110.0)).to_dict()])  # dicts accepted
    w = res.withheld["bag1"]
    assert {"distance_m", "fuel_economy_mpg", "mean_speed_mps"} <= set(w["quantities"])
    assert "fuel_mass_kg" not in w["quantities"]
    assert res.value("bag1", "fuel_mass_kg") is not None
    assert "check the template's unit and mapping of veh_spd_test" in w["fix"]
    assert "bag2" not in res.withheld


def test_a_whole_channel_finding_withholds_every_span():
    res = _res()
    f = Finding(signal="fuel_rate_test", kind=Kind.UNIT_SUSPECT, start_s=math.nan,
                end_s=math.nan, severity=Severity.ERROR, message="probably g/s, declared mg/s")
    apply_gate(res, [f])
    assert set(res.withheld) == {"bag1", "bag2", "test", "udds", "ftp75_from_udds"}


def test_warnings_and_other_signals_withhold_nothing():
    res = _res()
    before = json.dumps(res.to_dict())
    apply_gate(res, [_err("fuel_rate_test", sev=Severity.WARNING), _err("eng_spd_out_test"),
                     _err("fuel_rate_obd_test")])
    assert res.withheld == {} and json.dumps(res.to_dict()) == before


def test_force_states_the_figures_and_marks_them():
    res = _res()
    mpg = res.value("test", "fuel_economy_mpg")
    apply_gate(res, [_err("fuel_rate_test")], force=True)
    assert res.value("test", "fuel_economy_mpg") == mpg
    assert res.withheld["test"]["forced"] is True
    doc = res.to_dict()
    assert doc["forced"] is True and doc["withheld_count"] == 4
    assert doc["headline"]["forced"] is True and doc["headline"]["fuel_economy_mpg"] is not None


def test_phase_channel_error_withholds_phases_and_composites_not_the_whole_test():
    res = _res()
    apply_gate(res, [_err("test_phase_test", span=(0.0, 2000.0))])
    assert "test" not in res.withheld
    assert {"bag1", "bag2", "udds"} <= set(res.withheld)


def test_headline_is_the_last_run_of_a_two_run_hwfet_and_the_whole_test_otherwise():
    from vehval.cycles import load_cycle

    hw = load_cycle("hwfet").resampled(0.1)
    t1, v1 = np.asarray(hw.time_s), np.asarray(hw.speed_mps)
    gap = 15.0
    t = np.concatenate([t1, t1 + t1[-1] + gap])
    v = np.concatenate([v1, v1])
    sig = {"veh_spd": v, "fuel_rate": 0.2e-3 + 2e-5 * v, "test_phase": np.ones_like(t)}
    res = compute_results(make_test(t, sig, cycle="hwfet_x2", phase=False), fuel=EXPLICIT)
    h = headline(res)
    hw_comp = next(c for c in res.composites if c.name == "hwfet")
    assert h["name"] == "hwfet" and h["kind"] == "composite" and h["rule"] == hw_comp.rule
    assert h["fuel_economy_mpg"] == res.value("hwfet", "fuel_economy_mpg")
    # the whole test (preparation + test run) stays available under its own name
    assert res.value("test", "fuel_economy_mpg") != pytest.approx(h["fuel_economy_mpg"], rel=1e-6)
    t2, s2 = true_signals()
    plain = compute_results(make_test(t2, s2, cycle=""), fuel=EXPLICIT)
    hp = headline(plain)
    assert hp["name"] == "test" and hp["kind"] == "test"
    assert hp["fuel_economy_mpg"] == plain.value("test", "fuel_economy_mpg")


def test_exit_code_is_distinct():
    assert EXIT_WITHHELD == 4


def test_an_error_the_import_repaired_withholds_nothing():
    res = _res()
    f = _err("fuel_rate_test", kind=Kind.RATE_IRREGULAR, span=(-10.0, 2000.0))
    f.numbers = {"repaired_at_import": True}       # a repeated time stamp dropped at import
    apply_gate(res, [f])
    assert res.withheld == {}


def test_a_source_qa_dropped_for_an_error_is_withheld_not_merely_missing():
    t, s = true_signals()
    test = make_test(t, s)
    test.drop("fuel_rate_test")    # what the selection leaves when it drops the only source
    res = compute_results(test, fuel=EXPLICIT)
    assert "fuel" not in res.inputs and res.value("test", "fuel_economy_mpg") is None
    apply_gate(res, [_err("fuel_rate_test", kind=Kind.ALL_ZERO, span=(0.0, 0.0))])
    w = res.withheld["test"]
    assert w["signals"] == ["fuel_rate_test"] and "fuel_economy_mpg" in w["quantities"]
    assert headline(res)["withheld"] is not None
    assert res.value("test", "distance_m") is not None and "distance_m" not in w["quantities"]


def test_the_soc_correction_is_withheld_with_the_fuel_energy():
    t, s = true_signals()
    test = make_test(t, s)
    from vehval.test import Signal

    test.add(Signal.standard("ess_pwr_test", t, np.full(t.size, 2000.0), source="dyno"))
    res = compute_results(test, fuel=EXPLICIT)
    assert res.soc["status"] == "beyond_tolerance_uncorrected"
    assert any(f.message == res.soc["message"] for f in res.findings)
    apply_gate(res, [_err("fuel_rate_test", kind=Kind.UNIT_SUSPECT)])
    assert res.soc["status"] == "withheld" and "fuel_rate_test" in res.soc["message"]
    assert not any("battery net energy change" in f.message for f in res.findings)
    assert res.value("test", "ess_energy_net_j") is not None      # the battery is fine


def test_a_battery_signal_dropped_for_an_error_leaves_the_soc_check_undetermined():
    """A hybrid whose battery current QA dropped (sign flipped) had its J1711 status
    'not_applicable' (as a conventional car) and an unqualified headline."""
    from vehval.results.headline import headline_of

    res = _res()
    assert res.soc["status"] == "not_applicable"  # no battery signal in this test
    apply_gate(res, [_err("ess_curr_test", kind=Kind.SIGN_FLIP)])
    assert res.soc["status"] == "undetermined"
    assert "ess_curr_test has a QA error" in res.soc["message"]
    head = headline_of(res.to_dict())
    assert any("SAE J1711 undetermined: the battery signal ess_curr_test" in c
               for c in head.caveats)
    # a warning, or an error on another signal, says nothing about the battery
    res = _res()
    apply_gate(res, [_err("ess_curr_test", sev=Severity.WARNING), _err("amb_temp_test")])
    assert res.soc["status"] == "not_applicable"
