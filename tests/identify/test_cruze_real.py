"""Identification of the 2014 Cruze diesel from its own D3 files (skipped without them).

Identified from the hot UDDS (61410013) and the WLTC (61410004) only, with the A/C load
from the second bag of the 35 C A/C UDDS (61410021); the other hot tests are held out.
"""

from pathlib import Path

import numpy as np
import pytest

from helpers.data import CRUZE
from helpers.data import CRUZE_TEMPLATE as TEMPLATE

HERE = Path(__file__).resolve().parent
SPEC = HERE / "cruze_spec.yaml"

pytestmark = [pytest.mark.realdata, pytest.mark.slow,
              pytest.mark.skipif(not CRUZE.is_dir(), reason="real data not available")]


def _traces(*ids):
    from vehval.identify import load_traces
    return load_traces([CRUZE / f"{i} Test Data.txt" for i in ids], TEMPLATE)


@pytest.fixture(scope="module")
def identified():
    from vehval.identify import identify_conventional
    from vehval.identify.spec import load_spec
    return identify_conventional(_traces("61410013", "61410004"), "cruze_diesel_2014",
                                 ac_trace=_traces("61410021")[0], declared=load_spec(SPEC))


def test_gear_ratios_match_the_data_within_1_percent(identified):
    for row in identified.gear_ratio_check:
        if row["locked_samples"] >= 100:          # gears the converter locks in
            assert abs(row["rel_diff"]) < 0.01, row
    assert len(identified.gears.ratios) == 6


def test_road_load_reproduces_held_out_force(identified):
    from vehval.identify.roadload import check_road_load
    for tr in _traces("61410015", "61410016", "61410005", "61410026"):
        chk = check_road_load(identified.road_load, tr)
        # acceptance: R^2 > 0.97 and no steady offset beyond 30 N
        assert chk["r2"] > 0.97, chk
        assert abs(chk["mean_offset_n"]) < 30.0, chk
    # effective inertia agrees with the test mass of the template within 1 %
    rl = identified.road_load
    assert rl.values["mass_kg"] == pytest.approx(rl.template["mass_kg"], rel=0.01)


def test_identified_file_round_trips(identified, tmp_path):
    from vehval.identify import write_vehicle
    from vehval.vehicle import load_vehicle
    p = write_vehicle(identified.vehicle, tmp_path / "cruze.yaml")
    veh = load_vehicle(p)
    assert veh.architecture == "conventional"
    np.testing.assert_allclose(veh.gearbox.ratios, identified.gears.ratios, rtol=1e-12)
    assert "61410013" in veh.sources()["gearbox.ratios"]


def test_held_out_fuel_predictions(identified):
    """Held-out hot tests driven on their own speed traces (figures in docs/identification.md):
    HWFET test run, US06, NEDC and SC03 (A/C on) within 3 % each (acceptance)."""
    from vehval.identify import predict_trace
    veh = identified.vehicle
    got = {}
    for tr in _traces("61410015", "61410016", "61410005", "61410026"):
        p = predict_trace(veh, tr)
        got[tr.test_id[:8]] = p
        print(f"\n{tr.test_id} {tr.cycle}: {100 * p['error_rel']:+.2f} % "
              + ", ".join(f"{q.get('results_name', q['phase'])} {100 * q['error_rel']:+.1f} %"
                          for q in p["phases"]))
    assert abs(got["61410016"]["error_rel"]) < 0.03
    assert abs(got["61410005"]["error_rel"]) < 0.03
    run2 = [q for q in got["61410015"]["phases"] if q["phase"] == 2][0]
    assert abs(run2["error_rel"]) < 0.03
    assert got["61410026"]["ac_on"]                          # SC03 runs with the A/C on
    assert abs(got["61410026"]["error_rel"]) < 0.03
    # without the A/C load the SC03 is some 20 % short: the A/C model is what carries it
    off = predict_trace(veh, _traces("61410026")[0], ac="off")
    assert off["error_rel"] < -0.15


def test_ac_load_from_its_own_test(identified):
    ac = identified.ac
    assert ac["test"].startswith("61410021") and ac["phases"] == [2]
    assert 1000.0 < ac["ac_power_w"] < 6000.0      # a compressor at maximum A/C
    assert identified.vehicle.engine_control.ac_power_w == ac["ac_power_w"]
    assert not identified.vehicle.engine_control.ac_on


def test_driveline_drag_is_the_stated_share_of_the_dyno_losses(identified):
    d = identified.drag
    rl = identified.road_load
    assert d.share == 0.5
    assert d.dyno_loss_a_n == pytest.approx(100.69 - rl.values["road_load_a_n"])
    assert d.force_n == pytest.approx(0.5 * d.dyno_loss_a_n)
    assert identified.vehicle.gearbox.drag_force_n == pytest.approx(d.force_n)


def test_warmup_from_the_cold_and_hot_udds():
    """The 23 °C cold UDDS against the hot one: +23.5 % fuel at the start, fading with a
    589 s time constant (R² 0.996); the -7 °C cold start fades with the same time constant
    from a fraction over three times larger (the model has no temperature dependence)."""
    from vehval.identify import identify_conventional
    from vehval.identify.predict import predict_trace
    from vehval.identify.warmup import fit_warmup
    from vehval.vehicle import load_vehicle

    hot, cold, frozen = _traces("61410013", "61410012", "61410028")
    fit = fit_warmup(cold, hot)
    assert 0.15 < fit.fraction < 0.35 and 300.0 < fit.time_constant_s < 1200.0
    assert fit.r2 > 0.98
    for p in fit.phases:  # measured excess per bag: 55 g and 19 g
        assert p["fitted_excess_g"] == pytest.approx(p["cold_g"] - p["hot_g"], rel=0.1)
    low = fit_warmup(frozen, hot)
    assert low.time_constant_s == pytest.approx(fit.time_constant_s, rel=0.25)
    assert low.fraction > 3.0 * fit.fraction
    # the model with the warm-up predicts the cold test as well as the hot one
    idf = identify_conventional([hot, _traces("61410004")[0]], "cruze", cold_trace=cold)
    before = predict_trace(load_vehicle("cruze_diesel_2014"), cold)
    after = predict_trace(idf.vehicle, cold)
    hot_err = predict_trace(idf.vehicle, hot)["error_rel"]
    assert after["cold_start"] and not before["cold_start"]
    assert before["error_rel"] < -0.10
    assert abs(after["error_rel"] - hot_err) < 0.01
