"""Fuel meter against the engine map, quasi-steady / slow-sample masks, drift significance,
spike shape and corroboration, robust alignment: hand-constructed cases."""

from types import SimpleNamespace

import numpy as np
import pytest

from vehval.align import align_test
from vehval.qa.findings import Finding, Kind, Severity
from vehval.qa.fuelmap import FuelMapOptions, fuel_map_check, map_fuel_rate
from vehval.qa.level1 import run_level1
from vehval.qa.level3 import (
    Level3Options,
    quasi_steady_mask,
    residual_drift,
    slow_sample_mask,
)
from vehval.test import Signal, Test

from .helpers import make_test

RPM = 2 * np.pi / 60


def _engine(eff: float = 0.33):
    """A fuel map fuel = P / (eff * LHV) + idle flow, on a coarse grid [g/s]."""
    spd = np.array([800.0, 1500.0, 2500.0, 4000.0, 5200.0])
    trq = np.array([0.0, 20.0, 50.0, 80.0, 120.0])
    fuel = (spd[:, None] * RPM * trq[None, :] / (eff * 42.6e6) + 1e-4) * 1e3
    return SimpleNamespace(engine=SimpleNamespace(
        speed_rpm=spd.tolist(), torque_nm=trq.tolist(), fuel_rate_g_per_s=fuel.tolist(),
        max_torque_nm=[100.0, 110.0, 111.0, 111.0, 105.0], fire_speed_rpm=900.0))


def _engine_test(gain: float, seed: int = 1, duration: float = 200.0) -> Test:
    """Engine on at varying speed/torque (slow changes), fuel = gain x map + noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 0.1)
    w = (1800 + 800 * np.sin(t / 23.0)) * RPM
    trq = 55 + 35 * np.sin(t / 11.0 + 1.0)
    fmap = {"spd": np.array(_engine().engine.speed_rpm) * RPM,
            "trq": np.array(_engine().engine.torque_nm),
            "fuel": np.array(_engine().engine.fuel_rate_g_per_s) * 1e-3}
    fuel = gain * map_fuel_rate(fmap, w, trq) + rng.normal(0, 1e-5, t.size)
    return Test([Signal.standard("eng_spd_out_test", t, w + rng.normal(0, 0.2, t.size), source="dyno"),
                 Signal.standard("eng_trq_out_test", t, trq + rng.normal(0, 0.5, t.size), source="dyno"),
                 Signal.standard("fuel_rate_test", t, fuel, source="dyno")])


@pytest.mark.parametrize("gain,flag", [(1.0, False), (1.03, False), (1.08, True), (0.92, True)])
def test_fuel_map_gain(gain, flag):
    test = _engine_test(gain)
    rows, found = fuel_map_check(test, _engine(), [])
    # noise-free map, white noise only: the ratio-of-sums gain is exact to 0.5 %
    assert rows[0]["gain"] == pytest.approx(gain, abs=0.005)
    warn = [f for f in found if f.severity == Severity.WARNING]
    assert bool(warn) == flag
    if flag:
        f = warn[0]
        assert f.signal == "fuel_rate_test" and f.kind == Kind.FUEL_MAP and f.level == 3
        assert f"{abs(gain - 1) * 100:.0f} % {'high' if gain > 1 else 'low'}" in f.message
        assert f.start_s < 10 and f.end_s > 190     # spans the samples used


def test_fuel_map_needs_trusted_torque_and_a_map():
    test = _engine_test(1.08)
    assert fuel_map_check(test, None, []) == ([], [])          # no vehicle: no check
    bad = [Finding("eng_trq_out_test", Kind.OFFSET, 0.0, 200.0, Severity.WARNING, "drifts")]
    rows, found = fuel_map_check(test, _engine(), bad)
    # torque untrusted everywhere and no eng_trq_out_calc: no verdict, said as info
    assert rows == [] and [f.severity for f in found] == [Severity.INFO]
    # a torque finding over the second half only: the first half is enough
    half = [Finding("eng_trq_out_test", Kind.OFFSET, 100.0, 200.0, Severity.WARNING, "drifts")]
    rows, found = fuel_map_check(test, _engine(), half, opts=FuelMapOptions())
    assert rows[0]["gain"] == pytest.approx(1.08, abs=0.005) and rows[0]["duration_s"] < 101


def test_quasi_steady_and_slow_sample_masks():
    t = np.arange(0.0, 30.0, 0.1)
    w = np.where(t < 10, 100.0, np.where(t < 12, 100 + 50 * (t - 10), 200.0))   # 50 rad/s² ramp
    test = Test([Signal.standard("eng_spd_out_test", t, w, source="dyno"),
                 Signal.standard("mot_trq_out_obd_test", np.arange(0.3, 30, 1.0),
                                 np.zeros(30), source="obd")])
    m = quasi_steady_mask(test, t, acc_max=20.0, pad_s=0.5)
    # the ramp (10-12 s), widened by the 0.5 s average and the 0.5 s pad, is not steady
    assert not m[(t > 9.8) & (t < 12.2)].any()
    assert m[t < 9.0].all() and m[t > 13.0].all()
    mask, name = slow_sample_mask(test, {"mot_trq_out_obd_test", "eng_spd_out_test"}, t)
    assert name == "mot_trq_out_obd_test" and mask.sum() == 30
    assert np.allclose(t[mask], np.round(np.arange(0.3, 30, 1.0), 1))
    assert slow_sample_mask(test, {"eng_spd_out_test"}, t) == (None, None)


def test_drift_significance_rule():
    # a precise relation (noise 1 % of range) with a 2 % zero drift: below the 4 % size rule,
    # far above 20 block-median standard errors -> reported; a 0.5 % drift is not
    t = np.arange(0.0, 300.0, 0.1)
    rng = np.random.default_rng(3)
    x = 1000 * np.sin(t / 13.0)                      # range 2000
    for drift, found in ((40.0, True), (10.0, False)):
        meas = x + drift * t / t[-1] + rng.normal(0, 3.0, t.size)
        test = Test([Signal.standard("whl_trq_out_test", t, meas, source="dyno"),
                     Signal.standard("whl_trq_out_calc", t, x, source="calc")])
        f = residual_drift(test, "whl_trq_out_test", "whl_trq_out_calc", 2000.0, Level3Options())
        assert (f is not None) == found, drift
        if found:
            assert f.numbers["drift"] == pytest.approx(drift, rel=0.1)


def test_spike_shape_and_slow_partner_cannot_confirm():
    test = make_test(seed=21)
    s = test["veh_frc_in_test"]
    v = s.values.copy()
    i = int(np.searchsorted(s.time, 150.0))
    v[i] += 3000.0                                   # one-sample spike at 10 Hz
    j = int(np.searchsorted(s.time, 220.0))
    v[j:j + 6] += np.array([2500, 1200, 900, 700, 500, 300.0])   # edge + decay
    test.add(Signal.standard("veh_frc_in_test", s.time, v, source="dyno"), replace_existing=True)
    found = [f for f in run_level1(test) if f.signal == "veh_frc_in_test" and f.kind == Kind.SPIKE]
    at = {round(f.start_s): f.severity for f in found}
    assert at.get(150) == Severity.WARNING           # not confirmed by any 1 Hz OBD signal
    assert at.get(220) == Severity.INFO              # does not return: a transient


def test_alignment_ignores_invalid_pid_values():
    test = make_test(seed=5, obd_offset_s=3.3)
    s = test["veh_spd_obd_test"]
    v = s.values.copy()
    v[100:110] = 80.0                                # invalid speed PID for 10 s (> 70 m/s)
    test.add(Signal.standard("veh_spd_obd_test", s.time, v, source="obd"), replace_existing=True)
    r = align_test(test)[0]
    pair = next(p for p in r.pairs if p.other == "veh_spd_obd_test")
    # one 10 Hz sample is the requirement; the pair alone is sub-sample once the invalid
    # stretch is set aside
    assert abs(pair.offset_s - 3.3) < 0.05 and abs(r.offset_s - 3.3) < 0.05
