"""Driver model and the EPA trace tolerance check."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.sim.driver import MPH, driver_force, tolerance_band, trace_misses


def test_feed_forward_reaches_next_target():
    # on target: inertia force for the target acceleration plus road load
    f = driver_force(10.0, 10.0, 10.5, 0.5, 1300.0, 200.0, 0.0, 0.5, -1e4, 1e4)
    assert f == pytest.approx(1300 * 1.0 + 200)
    # 1 m/s behind with 0.5 s response: + m / 0.5 s per m/s
    f2 = driver_force(9.0, 10.0, 10.5, 0.5, 1300.0, 200.0, 0.0, 0.5, -1e4, 1e4)
    assert f2 == pytest.approx(f + 1300 / 0.5)
    assert driver_force(0.0, 10.0, 20.0, 0.1, 1300.0, 0.0, 0.0, 0.5, -1e4, 5e3) == 5e3


def test_tolerance_band_and_misses():
    t = np.arange(0.0, 10.0, 0.5)
    v = np.where(t < 5, 0.0, 10.0)  # a step at 5 s
    lo, hi = tolerance_band(t, v, 2 * MPH, 1.0)
    i = int(np.searchsorted(t, 4.5))
    assert hi[i] == pytest.approx(10 + 2 * MPH)  # the step is within 1 s
    assert lo[i] == 0.0
    assert trace_misses(t, v, v)["n_miss"] == 0
    late = np.where(t < 6.5, 0.0, 10.0)  # 1.5 s late: outside the ±1 s window
    m = trace_misses(t, v, late)
    assert m["n_miss"] > 0 and m["max_miss_mps"] == pytest.approx(10 - 2 * MPH)
