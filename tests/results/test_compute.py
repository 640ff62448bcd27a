"""The results stage on synthetic tests: phases, composites, fuel handling, uncertainty."""

import numpy as np
import pytest

from vehval.constants import MILE_M
from vehval.fuels import fuel_properties
from vehval.fuels.quantities import GALLON_US_M3
from vehval.qa.findings import Kind, Severity
from vehval.results import compute_results
from vehval.results.soc import regression_correction, soc_correction
from vehval.test import Signal

from .helpers import make_test, true_signals

EXPLICIT = {"density_kg_per_m3": 800.0, "lhv_j_per_kg": 42e6, "carbon_mass_fraction": 0.86}


def _hand(t, v, f, lo, hi):
    m = (t >= lo) & (t <= hi)
    return np.trapezoid(v[m], t[m]), np.trapezoid(f[m], t[m])


def test_phases_from_channel_and_hand_computed_fuel_economy():
    t, s = true_signals()
    res = compute_results(make_test(t, s), fuel=EXPLICIT)
    assert [p.name for p in res.phases] == ["bag1", "bag2"]
    assert res.phase_source == "phase channel test_phase_test"
    d, m = _hand(t, s["veh_spd"], s["fuel_rate"], 0.0, 504.95)
    mpg = d / MILE_M / (m / 800.0 / GALLON_US_M3)
    # the phase ends half a sample after its last sample: tolerance one sample of 1400
    assert res.value("bag1", "fuel_economy_mpg") == pytest.approx(mpg, rel=2e-3)
    whole_d, whole_m = _hand(t, s["veh_spd"], s["fuel_rate"], -1, 1e9)
    assert res.value("test", "distance_m") == pytest.approx(whole_d, rel=1e-12)
    assert res.value("test", "co2_kg") == pytest.approx(whole_m * 0.86 * 44.009 / 12.011, rel=1e-12)
    assert res.value("test", "fuel_energy_j") == pytest.approx(whole_m * 42e6, rel=1e-12)
    udds = next(c for c in res.composites if c.name == "udds")
    assert udds.groups == [(1.0, ["bag1", "bag2"])]
    # drive quality of a perfectly driven trace: zero ratings, no violation
    dq = res.drive_quality["bag2"]
    assert abs(dq["dr_pct"]) < 0.05 and dq["violations"] == 0 and dq["rmsse_mps"] < 0.05


def test_phases_from_cycle_without_channel():
    t, s = true_signals()
    res = compute_results(make_test(t, s, phase=False), fuel="diesel")
    assert [p.part for p in res.phases] == ["bag1", "bag2"]
    assert res.phase_source.startswith("cycle udds")
    assert res.phases[0].segments[0][1] == pytest.approx(505.0, abs=1.0)


def test_phase_channel_with_no_phases_is_a_finding_not_a_silent_number():
    t, s = true_signals()
    s["test_phase"] = np.zeros_like(t)
    res = compute_results(make_test(t, s), fuel="diesel")
    f = [f for f in res.findings if f.signal == "test_phase_test"]
    assert f and f[0].severity == Severity.WARNING and "holds no phase" in f[0].message
    assert res.phase_source.startswith("cycle udds")      # fell back, and says so


def test_mass_flow_without_fuel_gives_a_warning_and_no_volume_result():
    t, s = true_signals()
    res = compute_results(make_test(t, s), fuel=None)
    warn = [f for f in res.findings if f.kind == Kind.RESULTS and f.signal == "fuel_rate_test"]
    assert warn and "no fuel declared" in warn[0].message
    assert res.value("test", "fuel_economy_mpg") is None
    assert res.value("test", "fuel_volume_m3") is None
    assert res.value("test", "fuel_mass_kg") > 0               # mass is still measured


def test_ftp_weighting_from_a_cold_udds_with_a_hot_bag1():
    t, s = true_signals()
    hot = {"fuel_mass_kg": 0.2, "distance_m": 5800.0}
    res = compute_results(make_test(t, s, constants={}), fuel=EXPLICIT, hot_start_bag1=hot)
    ftp = next(c for c in res.composites if c.name == "ftp75_from_udds")
    v = res.values
    f12 = (v["bag1"]["fuel_mass_kg"] + v["bag2"]["fuel_mass_kg"]) / (
        v["bag1"]["distance_m"] + v["bag2"]["distance_m"])
    f32 = (0.2 + v["bag2"]["fuel_mass_kg"]) / (5800.0 + v["bag2"]["distance_m"])
    fpd = 0.43 * f12 + 0.57 * f32
    assert v["ftp75_from_udds"]["fuel_per_distance_kg_per_m"] == pytest.approx(fpd, rel=1e-12)
    mpg = GALLON_US_M3 / MILE_M / (fpd / 800.0)
    assert v["ftp75_from_udds"]["fuel_economy_mpg"] == pytest.approx(mpg, rel=1e-12)
    # harmonic weighting of the two halves' fuel economies
    fe = [GALLON_US_M3 / MILE_M / (x / 800.0) for x in (f12, f32)]
    assert mpg == pytest.approx(1 / (0.43 / fe[0] + 0.57 / fe[1]), rel=1e-12)
    assert "hot-start UDDS" in ftp.substitute


def _one_percent_meter():
    from vehval.io.template import AccuracySpec
    return {"fuel_rate_test": AccuracySpec(reading_pct=1.0),
            "veh_spd_test": AccuracySpec(reading_pct=0.0)}


def test_a_one_percent_fuel_meter_gives_about_one_percent():
    t, s = true_signals()
    res = compute_results(make_test(t, s), fuel=EXPLICIT, accuracy=_one_percent_meter())
    rel = res.expanded("test", "fuel_economy_mpg") / res.value("test", "fuel_economy_mpg")
    # rectangular +-1 %: u = 1 %/sqrt(3), U = 2u = 1.155 % (first order in 1/(1+g))
    assert rel == pytest.approx(0.02 / np.sqrt(3), rel=0.01)
    top = res.uncertainty["test"]["fuel_economy_mpg"]["contributors"][0]
    assert top["parameter"] == "fuel_rate_test reading" and top["share"] > 0.99
    assert top["assumed"] is False


def test_monte_carlo_agrees_with_first_order():
    t, s = true_signals()
    acc = _one_percent_meter()
    fo = compute_results(make_test(t, s), fuel="diesel", accuracy=acc)
    mc = compute_results(make_test(t, s), fuel="diesel", accuracy=acc, method="monte_carlo",
                         draws=4000, seed=3)
    u_fo = fo.expanded("bag2", "fuel_economy_mpg")
    u_mc = mc.expanded("bag2", "fuel_economy_mpg")
    assert u_mc == pytest.approx(u_fo, rel=0.06)              # 4000 draws: ~2 % scatter of u
    lo, hi = mc.uncertainty["bag2"]["fuel_economy_mpg"]["interval_95"]
    assert lo < mc.value("bag2", "fuel_economy_mpg") < hi
    # defaults are flagged as assumed, declared ones are not
    assert mc.accuracy["fuel_rate_test"].assumed is False
    assert fo.parameters and any(p.name.startswith("fuel density") for p in fo.parameters)


def _seeded_run(t, s, seed, acc_pct):
    """Measured signals: systematic errors drawn within the declared limits, plus noise."""
    rng = np.random.default_rng(seed)
    meas = dict(s)
    g_v, o_v = rng.uniform(-1, 1, 2) * np.array([acc_pct["v_gain"], acc_pct["v_off"]])
    g_f, o_f = rng.uniform(-1, 1, 2) * np.array([acc_pct["f_gain"], acc_pct["f_off"]])
    meas["veh_spd"] = s["veh_spd"] * (1 + g_v) + o_v + rng.normal(0, 0.02, t.size)
    meas["fuel_rate"] = s["fuel_rate"] * (1 + g_f) + o_f + rng.normal(0, 2e-5, t.size)
    return meas


def test_coverage_of_the_95_percent_interval_over_100_seeded_runs():
    from vehval.io.template import AccuracySpec
    t, s = true_signals()
    lim = {"v_gain": 0.005, "v_off": 0.02, "f_gain": 0.01, "f_off": 5e-6}
    acc = {"veh_spd_test": AccuracySpec(reading_pct=0.5, offset=0.02),
           "fuel_rate_test": AccuracySpec(reading_pct=1.0, offset=0.005, unit="g/s")}
    fuel = dict(EXPLICIT)
    truth = compute_results(make_test(t, s), fuel=fuel, accuracy=acc).value("test",
                                                                             "fuel_economy_mpg")
    covered, widths = 0, []
    for seed in range(100):
        res = compute_results(make_test(t, _seeded_run(t, s, seed, lim)), fuel=fuel, accuracy=acc)
        v, u = res.value("test", "fuel_economy_mpg"), res.expanded("test", "fuel_economy_mpg")
        covered += abs(v - truth) <= u
        widths.append(u / v)
    print(f"\ncoverage {covered} % of 100 runs, mean U {100 * np.mean(widths):.2f} %")
    assert 88 <= covered <= 100
    assert 0.005 < np.mean(widths) < 0.03


def test_soc_correction_statuses():
    vals = {"test": {"ess_energy_net_j": 0.5e6, "fuel_energy_j": 100e6, "fuel_economy_mpg": 50.0}}
    ok = soc_correction(vals, ["test"], battery=True)
    assert ok["status"] == "within_tolerance" and "uncorrected" in ok["message"]
    vals["test"]["ess_energy_net_j"] = 3e6
    bad = soc_correction(vals, ["test"], battery=True)
    assert bad["status"] == "beyond_tolerance_uncorrected" and "NOT corrected" in bad["message"]
    fixed = soc_correction(vals, ["test"], battery=True, factor=2.5)
    sc = fixed["scopes"]["test"]
    assert fixed["method"] == "charge_balance_factor"
    assert sc["fuel_energy_corrected_j"] == pytest.approx(107.5e6)
    assert sc["fuel_economy_mpg_corrected"] == pytest.approx(50.0 / 1.075)
    assert soc_correction(vals, ["test"], battery=False)["status"] == "not_applicable"
    # a battery without any fuel energy (an ADVISOR or OBD log with no fuel channel): the
    # ratio cannot be formed, so no "within tolerance" verdict on a missing denominator
    none = soc_correction({"test": {"ess_energy_net_j": -27.2e3, "fuel_energy_j": None}},
                          ["test"], battery=True)
    assert none["status"] == "undetermined"
    assert none["message"].startswith("battery net energy change -27.2 kJ but no fuel energy")


def test_soc_regression_recovers_the_intercept():
    x = [-0.03, -0.01, 0.02, 0.04]
    y = [5e-5 * (1 - 0.8 * xi) for xi in x]
    r = regression_correction(x, y)
    assert r["corrected"] == pytest.approx(5e-5, rel=1e-9) and r["r2"] == pytest.approx(1.0)


def test_battery_energy_from_voltage_and_current():
    t, s = true_signals()
    test = make_test(t, s)
    test.add(Signal.standard("ess_volt_test", t, np.full(t.size, 200.0)))
    test.add(Signal.standard("ess_curr_test", t, 5.0 * np.sin(t / 50.0)))
    res = compute_results(test, fuel=fuel_properties("gasoline_e10"))
    expect = np.trapezoid(200.0 * 5.0 * np.sin(t / 50.0), t)
    assert res.value("test", "ess_energy_net_j") == pytest.approx(expect, rel=1e-9)
    assert res.soc["status"] in ("within_tolerance", "beyond_tolerance_uncorrected")
    assert "ess_curr_test offset" in {p.name for p in res.parameters}


def test_ftp75_with_a_hot_soak_gets_three_bags_and_the_weighting():
    from vehval.cycles import load_cycle
    udds = load_cycle("udds").resampled(0.1)
    t1, v1 = np.asarray(udds.time_s), np.asarray(udds.speed_mps)
    soak = np.arange(1369.1, 1969.0, 0.1)
    m3 = t1 <= 505.0
    t = np.concatenate([t1, soak, 1969.0 + t1[m3]])
    v = np.concatenate([v1, np.zeros(soak.size), v1[m3]])
    fuel = 0.15e-3 + 2e-4 * v
    res = compute_results(make_test(t, {"veh_spd": v, "fuel_rate": fuel,
                                        "test_phase": np.zeros_like(t)}, cycle="ftp75", phase=False),
                          fuel=EXPLICIT)
    assert [p.part for p in res.phases] == ["bag1", "bag2", "bag3"]
    bag3 = res.phases[2].segments[0]
    assert bag3[0] == pytest.approx(1969.0, abs=1.5) and bag3[1] - bag3[0] == pytest.approx(505, abs=1.5)
    ftp = next(c for c in res.composites if c.name == "ftp75")
    assert ftp.groups == [(0.43, ["bag1", "bag2"]), (0.57, ["bag3", "bag2"])]
    assert res.value("bag3", "distance_m") == pytest.approx(res.value("bag1", "distance_m"), rel=0.01)


def test_results_use_the_cycle_match_kept_at_import(monkeypatch):
    """The import keeps the whole match in the metadata; the results stage places the phases
    with it (shifted with its source by alignment) and never searches the record again."""
    import vehval.cycles_match as cm
    from vehval.io.importer import set_cycle

    t, s = true_signals()
    test = make_test(t + 30.0, s, phase=False)
    test.meta.cycle = ""
    set_cycle(test)
    m = test.meta.cycle_match
    assert test.meta.cycle == m["name"] == "udds" and m["method"] == "cycle"
    assert m["signal"] == "veh_spd_test" and m["source"] == "dyno" and m["score"] > 0.9
    assert m["offsets_s"] == [30.0] and m["source_offset_s"] == 0.0

    def no_search(*a, **k):
        raise AssertionError("the results stage searched the record again")

    monkeypatch.setattr(cm, "identify_cycle", no_search)
    res = compute_results(test, fuel="diesel")
    assert res.phase_source.startswith("cycle udds")
    assert res.phases[0].segments[0] == pytest.approx((30.0, 535.0), abs=0.2)
    test.shift_source("dyno", -2.5)            # alignment after import moves the match too
    res = compute_results(test, fuel="diesel")
    assert res.phases[0].segments[0] == pytest.approx((27.5, 532.5), abs=0.2)


def _fast_driver_findings(monkeypatch) -> list:
    """The drive-quality findings (metric) of a driver 5 % fast: IWR about +10 %, outside
    -2..+4 % at 10 Hz and at 1 Hz alike."""
    t, s = true_signals()
    s["veh_spd"] = 1.05 * s["veh_spd"]
    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    res = compute_results(make_test(t, s), fuel="diesel")
    return [f for f in res.findings if f.kind == Kind.DRIVE_QUALITY]


def test_drive_quality_finding_reads_in_display_units_and_explains_iwr(monkeypatch):
    dq = _fast_driver_findings(monkeypatch)
    assert dq and all(f.severity == Severity.WARNING for f in dq)
    msg = dq[0].message
    assert " km/h (allowed 1.29 km/h)" in msg and "mph" not in msg, msg
    assert "also outside the band: the driver's speed changes" in msg, msg
    assert dq[0].numbers["iwr_1hz_pct"] > 4.0


def test_drive_quality_finding_states_the_rmsse_to_the_digits_of_its_tolerance(monkeypatch):
    # "RMSSE 1.3 km/h (allowed 1.29 km/h)" for a 1.27 km/h RMSSE within the tolerance: the
    # value was cut to two significant digits, its tolerance to three
    import re

    from vehval.display import as_unit

    dq = _fast_driver_findings(monkeypatch)
    assert dq
    for f in dq:
        shown = float(re.search(r"RMSSE (\S+) km/h \(allowed", f.message).group(1))
        assert shown == pytest.approx(as_unit(f.numbers["rmsse_mps"], "km/h"), abs=0.006), \
            f.message


def test_an_obd_speed_gets_the_obd_class_default_not_the_roll_speed():
    # the Prius c OBD log's speed was assumed 0.1 % / 0.01 m/s "chassis-dyno roll speed"
    from vehval.results.uncertainty import channel_accuracy

    obd = channel_accuracy("veh_spd_obd_test", None)
    assert obd.gain_limit == pytest.approx(0.02) and obd.offset_limit == pytest.approx(0.5 / 3.6)
    assert obd.assumed and "J1979" in obd.basis
    roll = channel_accuracy("veh_spd_test", None)
    assert roll.gain_limit == pytest.approx(0.001) and "roll speed" in roll.basis


def test_a_volume_fuel_meter_puts_the_density_spread_on_the_mass_not_the_volume():
    # A meter of volume (ccps, the D3 Camry's Eng_FuelFlow_Direct_DI) measures the volume:
    # its mpg and L/100 km do not depend on the fuel density (imported mass / density gives
    # back the measured volume exactly), while its fuel mass, energy and CO2 do. The density
    # spread was put on the volume figures and left off the mass (Camry 61811012: U 0.59 mpg,
    # 26 % of the variance from the density; 0.50 mpg without it).
    t, s = true_signals()
    test = make_test(t, s)
    test["fuel_rate_test"].raw_unit = "ccps"
    acc = _one_percent_meter()
    vol = compute_results(test, fuel="gasoline_e10", accuracy=acc)
    mass = compute_results(make_test(t, s), fuel="gasoline_e10", accuracy=acc)
    names = {q: [c["parameter"] for c in vol.uncertainty["test"][q]["contributors"]]
             for q in ("fuel_economy_mpg", "fuel_volume_m3", "fuel_mass_kg", "co2_kg")}
    for scope in ("test", "udds"):
        rel = vol.expanded(scope, "fuel_economy_mpg") / vol.value(scope, "fuel_economy_mpg")
        # the 1 % meter alone: U = 2 x 1 %/sqrt(3) (first order in 1/(1+g)), as a mass meter
        # without the density's spread
        assert rel == pytest.approx(0.02 / np.sqrt(3), rel=0.01), scope
        assert vol.value(scope, "fuel_economy_mpg") == pytest.approx(
            mass.value(scope, "fuel_economy_mpg"), rel=1e-12)    # nominal figures unchanged
    assert "fuel density_kg_per_m3" not in names["fuel_economy_mpg"] + names["fuel_volume_m3"]
    assert "fuel density_kg_per_m3" in names["fuel_mass_kg"] and "fuel density_kg_per_m3" in names["co2_kg"]
    # the mass carries the density's relative spread: 5 kg/m3 of 745.5, rectangular
    u_rho = 5.0 / 745.5 / np.sqrt(3)
    u_rel = vol.uncertainty["test"]["fuel_mass_kg"]["u"] / vol.value("test", "fuel_mass_kg")
    assert u_rel == pytest.approx(np.hypot(0.01 / np.sqrt(3), u_rho), rel=1e-3)
    # a mass meter keeps the density on the volume figures
    assert "fuel density_kg_per_m3" in [c["parameter"] for c in
                                        mass.uncertainty["test"]["fuel_economy_mpg"]["contributors"]]
