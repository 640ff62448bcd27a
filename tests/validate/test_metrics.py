"""Metrics against hand-computed cases (exact arithmetic: tolerances are float rounding)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehval.validate import metrics as M


def test_rmse_mad_bias_hand_case():
    test = np.array([1.0, 2.0, 3.0, 4.0])
    sim = np.array([2.0, 2.0, 1.0, 4.0])  # d = 1, 0, -2, 0
    assert M.rmse(test, sim) == pytest.approx(math.sqrt(5.0 / 4.0), rel=1e-12)
    assert M.mean_abs_diff(test, sim) == pytest.approx(3.0 / 4.0, rel=1e-12)
    assert M.bias(test, sim) == pytest.approx(-1.0 / 4.0, rel=1e-12)


def test_r_squared_hand_case():
    test = np.array([1.0, 2.0, 3.0, 4.0])  # mean 2.5, SS_tot = 5
    sim = np.array([2.0, 2.0, 1.0, 4.0])   # SS_res = 5
    assert M.r_squared(test, sim) == pytest.approx(0.0, abs=1e-12)
    assert M.r_squared(test, test) == 1.0
    assert M.r_squared(test, np.array([1.0, 2.0, 3.0, 5.0])) == pytest.approx(1 - 1 / 5, rel=1e-12)
    assert math.isnan(M.r_squared(np.ones(4), np.arange(4.0)))  # constant test


def test_nan_pairs_are_ignored():
    test = np.array([1.0, np.nan, 3.0])
    sim = np.array([1.0, 5.0, np.nan])
    m = M.signal_metrics(test, sim)
    assert m["n"] == 1 and m["rmse"] == 0.0


def test_energies_split_sign_trapezoid():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    p = np.array([10.0, 10.0, -20.0, -20.0])
    pos, neg = M.energies(t, p)
    # clipped: max(p,0) = 10,10,0,0 -> 10 + 5 + 0 = 15; min(p,0) = 0,0,-20,-20 -> 0 - 10 - 20 = -30
    assert pos == pytest.approx(15.0) and neg == pytest.approx(-30.0)


def test_relative_error():
    assert M.relative_error(2.0, 2.1) == pytest.approx(0.05)
    assert M.relative_error(-2.0, -2.1) == pytest.approx(-0.05)
    assert math.isnan(M.relative_error(0.0, 1.0))


def test_on_off_events_and_agreement():
    t = np.arange(10.0)
    on = np.array([0, 0, 1, 1, 1, 0, 0, 1, 1, 0], float)
    starts, stops = M.on_off_events(t, on)
    np.testing.assert_array_equal(starts, [2.0, 7.0])
    np.testing.assert_array_equal(stops, [5.0, 9.0])
    other = np.array([0, 0, 0, 1, 1, 1, 0, 1, 1, 0], float)  # differs at 2 and 5
    assert M.on_agreement(on, other) == pytest.approx(0.8)
    # NaN holds the previous state
    s2, p2 = M.on_off_events(t, np.array([0, np.nan, 1, np.nan, 1, 0, 0, 0, 0, 0], float))
    np.testing.assert_array_equal(s2, [2.0])
    np.testing.assert_array_equal(p2, [5.0])


def test_match_events_one_to_one_within_window():
    test = [10.0, 20.0, 30.0, 50.0]
    sim = [11.0, 19.5, 21.0, 33.5, 80.0]
    m = M.match_events(test, sim, window_s=2.0)
    # 20 pairs with 19.5 (closest), 10 with 11; 21 cannot reuse 20; 30 has nothing within 2 s
    assert m.pairs == [(10.0, 11.0), (20.0, 19.5)]
    assert m.missed == [30.0, 50.0]
    assert m.extra == [21.0, 33.5, 80.0]
    assert m.matched_share == pytest.approx(2 / 5)
    assert m.mean_lag_s == pytest.approx((1.0 - 0.5) / 2)
    wide = M.match_events(test, sim, window_s=4.0)
    assert (30.0, 33.5) in wide.pairs
    assert M.match_events([], [], 1.0).matched_share == 1.0


def test_match_events_greedy_prefers_closest():
    m = M.match_events([0.0, 1.0], [0.9], window_s=2.0)
    assert m.pairs == [(1.0, 0.9)] and m.missed == [0.0]


def test_speed_smoothing_is_zero_phase_low_pass():
    from vehval.errors import ConfigError
    from vehval.validate.conditions import smooth_speed

    t = np.arange(0.0, 200.0, 0.1)  # 10 Hz
    slow = 10.0 + 2.0 * np.sin(2 * np.pi * 0.05 * t)  # 0.05 Hz: a driving manoeuvre
    ripple = 0.2 * np.sin(2 * np.pi * 3.0 * t)  # 3 Hz: sensor / tracking ripple
    tu, v = smooth_speed(t, slow + ripple, 1.0)
    assert np.allclose(tu, t)
    inner = slice(200, -200)  # away from the filtfilt edge transients
    # 2nd-order Butterworth run twice: |H(f)|^2 = 1 / (1 + (f/fc)^4) for the analog prototype
    # -> 0.05 Hz passes to 6e-6 and without phase shift (filtfilt), 3 Hz is cut to 1 / 82 =
    # 1.2 % (0.0024 m/s) or less (the bilinear transform attenuates more near Nyquist)
    # (a lag of only 0.05 s would already leave 2 x 2 pi x 0.05 x 0.05 = 0.03 m/s)
    err = v[inner] - slow[inner]
    assert np.max(np.abs(err)) < 0.2 / 82 * 1.1 + 1e-4
    # a stop: the filter's undershoot before the standstill is clipped to 0
    step = np.where(t < 100.0, 5.0, 0.0)
    _, vs = smooth_speed(t, step, 1.0)
    assert vs.min() == 0.0 and np.all(vs[t > 110.0] < 1e-3)
    with pytest.raises(ConfigError, match="Nyquist"):
        smooth_speed(t, slow, 6.0)
    with pytest.raises(ConfigError, match="positive"):
        smooth_speed(t, slow, 0.0)
