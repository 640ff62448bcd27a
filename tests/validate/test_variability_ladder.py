"""Variability of repeats and ladder verdicts on hand-built tests (no simulator needed)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehval.errors import ConfigError, VehvalError
from vehval.validate.compare import compare
from vehval.validate.ladder import Tolerances, ladder, rung_of, verdict
from vehval.validate.variability import error_vs_repeatability, stats, variability

from .helpers import hand_test


def test_stats_hand_case():
    s = stats([1.0, 2.0, 4.0])
    assert s["mean"] == pytest.approx(7 / 3)
    var = ((1 - 7 / 3) ** 2 + (2 - 7 / 3) ** 2 + (4 - 7 / 3) ** 2) / 2  # ddof = 1
    assert s["std"] == pytest.approx(math.sqrt(var))
    assert s["cv"] == pytest.approx(math.sqrt(var) / (7 / 3))
    assert s["spread"] == 3.0 and s["n"] == 3
    assert math.isnan(stats([1.0])["std"])


def test_variability_of_hand_repeats():
    fuels = [0.50, 0.52, 0.49, 0.51]
    socs = [0.58, 0.575, 0.585, 0.58]
    tests = [hand_test(fuel_g_per_s=f, soc1=s, test_id=f"r{i}") for i, (f, s) in enumerate(zip(fuels, socs))]
    v = variability(tests, dt=1.0)
    # fuel mass = rate x on time (40 s of 1 Hz samples: trapezoid gives 39.5 + 2 x 0.5 ramp = 40 s
    # of full rate minus the half steps at both edges: 39 s full + 0.5 + 0.5 = 40 s)
    expect = np.array(fuels) * 1e-3 * 40.0
    np.testing.assert_allclose(v.values["fuel_mass_kg"], expect, rtol=1e-12)
    assert v.stats["fuel_mass_kg"]["std"] == pytest.approx(np.std(expect, ddof=1), rel=1e-12)
    dsoc = np.array(socs) - 0.6
    assert v.stats["soc_delta"]["mean"] == pytest.approx(dsoc.mean(), abs=1e-12)
    assert v.stats["soc_delta"]["std"] == pytest.approx(np.std(dsoc, ddof=1), rel=1e-9)
    assert v.stats["engine_on_share"]["std"] == 0.0
    assert v.tables()[0]["rows"]
    with pytest.raises(VehvalError):
        variability(tests[:1])


def test_error_vs_repeatability():
    tests = [hand_test(fuel_g_per_s=f, test_id=f"r{i}") for i, f in enumerate([0.50, 0.52, 0.49, 0.51])]
    v = variability(tests, dt=1.0)
    sim = hand_test(fuel_g_per_s=0.60, origin="simu")
    comp = compare(tests[0], sim, dt=1.0)
    rows = {r["quantity"]: r for r in error_vs_repeatability(comp, v)}
    sd = v.stats["fuel_mass_kg"]["std"]
    assert rows["fuel_mass_kg"]["error"] == pytest.approx(0.1e-3 * 40.0, rel=1e-9)
    assert rows["fuel_mass_kg"]["ratio"] == pytest.approx(0.004 / sd, rel=1e-9)
    assert rows["fuel_mass_kg"]["verdict"] == "model error"


def test_compare_hand_case_and_events():
    test = hand_test(fuel_g_per_s=0.5, soc1=0.58, on_from_s=20, on_to_s=60)
    sim = hand_test(fuel_g_per_s=0.52, soc1=0.57, origin="simu", on_from_s=21, on_to_s=65)
    c = compare(test, sim, dt=1.0, window_s=2.0)
    assert c.on_method == "speed"
    assert c.fuel_error == pytest.approx((0.52 * 44 - 0.5 * 40) / (0.5 * 40), rel=1e-9)
    assert c.soc_delta_error == pytest.approx(-0.01, abs=1e-12)
    # engine states differ at t = 20 and t = 60..64: 6 of 101 steps
    assert c.on_agreement == pytest.approx(95 / 101)
    assert c.starts.pairs == [(20.0, 21.0)] and c.stops.missed == [60.0] and c.stops.extra == [65.0]
    rows = {r[0]: r for r in c.summary_rows()}
    assert rows["fuel mass"][2] == pytest.approx(20.0) and rows["fuel mass"][3] == pytest.approx(22.88)
    assert rows["fuel mass"][5] == pytest.approx(14.4)
    assert c.signals["veh_spd"]["rmse"] == 0.0
    assert "eng_pwr_out" in c.signals  # derived from torque x speed on both sides
    assert set(c.overlays.columns) >= {"time", "veh_spd_test", "veh_spd_simu", "eng_on_test"}


def test_ladder_verdicts_and_rungs():
    assert rung_of("steady_60kph_300s") == "steady"
    assert rung_of("Japan 10-15") == "low_transient" and rung_of("nedc_measured") == "low_transient"
    assert rung_of("US06") == "high_transient" and rung_of("hwfet") == "high_transient"
    assert rung_of("mystery") == "other"
    test = hand_test(fuel_g_per_s=0.5, soc1=0.58, cycle="udds", test_id="u")
    good = compare(test, hand_test(fuel_g_per_s=0.51, soc1=0.585, origin="simu"), dt=1.0)
    bad = compare(hand_test(cycle="nedc", test_id="n"),
                  hand_test(fuel_g_per_s=0.6, soc1=0.58, origin="simu"), dt=1.0)
    ok, fails, err = verdict(good, Tolerances())
    # fuel +2 %; SOC: |(0.585-0.6) - (0.58-0.6)| / 0.58 = 0.862 %
    assert ok and err["fuel_pct"] == pytest.approx(2.0) and err["soc_pct"] == pytest.approx(0.5 / 0.58)
    assert err["soc_points"] == pytest.approx(0.5)
    res = ladder([good, bad])
    assert [e.rung for e in res.entries] == ["low_transient", "high_transient"]
    assert not res.passed and res.rung_passed()["high_transient"] is True
    assert res.highest_rung_passed() is None  # the low-transient rung fails first
    assert "fuel_pct" in res.entries[0].failures[0]
    assert ladder([good, bad], {"fuel_pct": 25}).passed
    assert not ladder([good], {"soc_points": 0.1}).passed
    with pytest.raises(ConfigError):
        Tolerances.from_mapping({"fuel": 3})


def test_ladder_marks_in_sample_tests():
    good = compare(hand_test(fuel_g_per_s=0.5, soc1=0.58, cycle="udds", test_id="u"),
                   hand_test(fuel_g_per_s=0.51, soc1=0.585, origin="simu"), dt=1.0)
    bad = compare(hand_test(cycle="nedc", test_id="n"),
                  hand_test(fuel_g_per_s=0.6, soc1=0.58, origin="simu"), dt=1.0)
    res = ladder([good, bad], calibrated={"u": ["controller.soc_gain_w"]})
    assert {e.test_id: e.in_sample for e in res.entries} == {"u": True, "n": False}
    assert res.sample_counts() == {"n_held_out": 1, "n_held_out_passed": 0,
                                   "n_in_sample": 1, "n_in_sample_passed": 1}
    assert res.summary().startswith("held-out: 0/1 tests pass; in-sample")
    d = res.to_dict()
    assert d["n_in_sample_passed"] == 1 and d["calibration_tests"] == {"u": ["controller.soc_gain_w"]}
    assert [r[-1] for r in d["tables"][0]["rows"]] == ["held-out", "in-sample"]
    assert ladder([good, bad]).summary() == "held-out: 1/2 tests pass"
