"""QA level 1: every kind is detected on the right signal and span; clean signals are quiet."""

import numpy as np
import pytest

from vehval.qa.findings import Kind, Severity
from vehval.qa.level1 import check_signal, run_level1
from vehval.test import Signal

from .helpers import make_test


def _kinds(findings, name, min_sev=Severity.INFO):
    return {f.kind for f in findings if f.signal == name and f.severity.rank >= min_sev.rank}


def _replace(test, name, values=None, time=None):
    s = test[name]
    test.add(Signal.standard(name, s.time if time is None else time,
                             s.values if values is None else values, source=s.source),
             replace_existing=True)


def test_clean_test_has_no_warning():
    test = make_test(seed=11)
    bad = [f for f in run_level1(test) if f.severity != Severity.INFO]
    assert bad == [], [f.message for f in bad]


@pytest.mark.parametrize("seed", [12, 13])
def test_each_injected_kind_found_on_right_signal(seed):
    test = make_test(seed=seed)
    t = test["eng_spd_out_test"].time
    span = {}
    # spike on engine speed at 100 s
    v = test["eng_spd_out_test"].values.copy()
    i = np.searchsorted(t, 100.0)
    v[i] += 300.0
    _replace(test, "eng_spd_out_test", v)
    span["eng_spd_out_test"] = (Kind.SPIKE, 100.0, 100.0)
    # stuck wheel torque 150..170 s
    w = test["whl_trq_out_test"].values.copy()
    j0, j1 = np.searchsorted(t, [150.0, 170.0])
    w[j0:j1] = w[j0]
    if w[j0] == 0:
        w[j0:j1] = 12.5
    _replace(test, "whl_trq_out_test", w)
    span["whl_trq_out_test"] = (Kind.STUCK, 150.0, 170.0)
    # NaN gap in the force 50..60 s
    f = test["veh_frc_in_test"].values.copy()
    k0, k1 = np.searchsorted(t, [50.0, 60.0])
    f[k0:k1] = np.nan
    _replace(test, "veh_frc_in_test", f)
    span["veh_frc_in_test"] = (Kind.NAN_GAP, 50.0, 60.0)
    # all-zero current, negative fuel rate, out of range voltage
    _replace(test, "ess_curr_test", np.zeros(t.size))
    span["ess_curr_test"] = (Kind.ALL_ZERO, 0.0, t[-1])
    fr = test["fuel_rate_test"].values.copy()
    fr[(t > 200) & (t < 210)] = -5e-4
    _replace(test, "fuel_rate_test", fr)
    span["fuel_rate_test"] = (Kind.NEGATIVE, 200.0, 210.0)
    vo = test["ess_volt_test"].values.copy()
    vo[(t > 30) & (t < 33)] = 2000.0
    _replace(test, "ess_volt_test", vo)
    span["ess_volt_test"] = (Kind.RANGE, 30.0, 33.0)
    # time gap in the OBD file
    s = test["veh_spd_obd_test"]
    keep = (s.time < 120) | (s.time > 140)
    _replace(test, "veh_spd_obd_test", s.values[keep], s.time[keep])
    span["veh_spd_obd_test"] = (Kind.TIME_GAP, 120.0, 140.0)
    found = run_level1(test)
    for name, (kind, t0, t1) in span.items():
        hits = [f for f in found if f.signal == name and f.kind == kind
                and f.severity != Severity.INFO and f.overlaps(t0 - 0.5, t1 + 0.5)]
        assert hits, (name, kind, [(f.kind, f.start_s, f.end_s) for f in found if f.signal == name])
    # nothing of warning level on the signals left clean
    for name in ("eng_trq_out_test", "mot_trq_out_obd_test", "gen_spd_out_obd_test"):
        assert _kinds(found, name, Severity.WARNING) == set()


def test_vehicle_limit_and_constant_and_unrecognised():
    test = make_test(seed=14)
    limits = {"eng_spd_out": (0.0, 150.0)}
    f = check_signal(test, test["eng_spd_out_test"], limits)
    assert Kind.VEHICLE_LIMIT in _kinds(f, "eng_spd_out_test", Severity.ERROR)
    t = np.arange(0, 60, 0.1)
    const = Signal.standard("mot_trq_out_test", t, np.full(t.size, 3.0), source="dyno")
    assert _kinds(check_signal(test, const), "mot_trq_out_test", Severity.WARNING) == {Kind.CONSTANT}
    odd = Signal("foo_bar_test", t, t, unit="1", source="dyno")
    assert _kinds(check_signal(test, odd), "foo_bar_test") == {Kind.UNRECOGNISED}


def test_legitimately_constant_signals_are_not_stuck():
    t = np.arange(0, 300, 0.1)
    from vehval.test import Test
    # quantised temperature flat for minutes, SOC flat, speed zero at idle: no stuck finding
    temp = np.round(90 + 0.01 * t)                     # 1 °C steps
    soc = np.round((0.6 + 0.0001 * t) * 200) / 200      # 0.5 % steps
    spd = np.where(t < 100, 0.0, np.minimum(t - 100, 20.0))
    test = Test([Signal.standard("eng_temp_coolant_test", t, temp, source="dyno"),
                 Signal.standard("ess_soc_test", t, soc, source="dyno"),
                 Signal.standard("veh_spd_test", t, spd, source="dyno")])
    found = run_level1(test)
    assert not [f for f in found if f.kind == Kind.STUCK], [f.message for f in found]


def test_jittery_obd_rate_is_info_only():
    test = make_test(seed=15)
    f = check_signal(test, test["eng_spd_out_obd_test"])
    rate = [x for x in f if x.kind == Kind.RATE_IRREGULAR]
    assert all(x.severity == Severity.INFO for x in rate)


def test_backwards_time_is_error():
    t = np.array([0.0, 0.1, 0.2, 0.15, 0.3, 0.4])
    from vehval.test import Test
    s = Signal.standard("veh_spd_test", t, np.arange(6.0), source="dyno")
    f = check_signal(Test([s]), s)
    assert any(x.kind == Kind.RATE_IRREGULAR and x.severity == Severity.ERROR for x in f)


def test_small_negative_share_is_not_shown_as_zero_percent():
    """5 negative samples of 36 000 (0.0139 %): the message says 0.014 %, not 0.0 %."""
    from vehval.test import Test
    t = np.arange(0, 3600, 0.1)
    fuel = 4e-4 + 1e-4 * np.sin(t / 30)                     # [kg/s] 0.3-0.5 g/s
    fuel[[1000, 9000, 17000, 25000, 33000]] = -2e-5
    s = Signal.standard("fuel_rate_test", t, fuel, source="dyno")
    neg = [f for f in check_signal(Test([s]), s) if f.kind == Kind.NEGATIVE]
    assert len(neg) == 1
    assert neg[0].numbers["fraction"] == pytest.approx(5 / t.size)
    assert "(0.014 % of samples" in neg[0].message, neg[0].message
