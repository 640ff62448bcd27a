"""Fuel-model coefficients fitted on block sums (``fit_fuel_map(..., block_s=...)``)."""

import numpy as np
import pytest

from vehval.identify.fuelmap import _meter, fit_fuel_map
from vehval.identify.traces import Trace, smooth

IDLE = 86.0  # [rad/s]
TRUE = {"c0": 2.0e-5, "c1": 1.0e-6, "c2": 2.0e-9, "d0": 5.0e-8, "d1": 1.0e-10}


def _trace(seed: int, delay_s: float, jitter_s: float = 0.0):
    """A 1200 s virtual test: speed, engine speed and power, fuel through the meter."""
    rng = np.random.default_rng(seed)
    dt = 0.1
    t = np.arange(0.0, 1200.0, dt)
    v = np.clip(smooth(np.cumsum(rng.normal(0, 0.3, t.size)), 50) + 12.0, 0.0, None)
    v[:200] = 0.0
    w = np.where(v > 0.05, 100.0 + 8.0 * v + 20 * np.sin(t / 7.0), IDLE)
    p = np.where(v > 0.05, smooth(rng.gamma(2.0, 6e3, t.size), 30), 0.0)
    c = TRUE
    rate = np.where(v > 0.05, c["c0"] + c["c1"] * w + c["c2"] * w * w + (c["d0"] + c["d1"] * w) * p,
                    1.9e-4)
    if jitter_s:  # a meter delay that wanders (exhaust transport varies with the flow)
        shift = jitter_s * np.sin(t / 13.0)
        rate = np.interp(t - shift, t, rate)
    fuel = _meter(rate[:, None], dt, delay_s, 1.0)[:, 0]
    tr = Trace(test_id=f"virtual {seed}", cycle=f"c{seed}", t=t, v=v, a=np.gradient(v, dt),
               force=np.zeros_like(t), w_eng=w, fuel=fuel, phase=np.ones(t.size))
    return tr, p


@pytest.mark.parametrize("block_s", [None, 5.0, 10.0])
def test_coefficients_recovered_with_and_without_blocks(block_s):
    pairs = [_trace(1, 1.6), _trace(2, 1.6)]
    fm = fit_fuel_map([a for a, _ in pairs], [b for _, b in pairs], IDLE, meter=(1.6, 1.0),
                      cut_rad_s=1.5 * IDLE, block_s=block_s)
    w = np.array([120.0, 200.0, 280.0])
    p = np.array([5e3, 15e3, 30e3])
    true = TRUE["c0"] + TRUE["c1"] * w + TRUE["c2"] * w * w + (TRUE["d0"] + TRUE["d1"] * w) * p
    np.testing.assert_allclose(fm.rate(w, p), true, rtol=0.01)
    assert fm.idle_fuel_kg_s == pytest.approx(1.9e-4, rel=0.01)
    assert fm.r2 > 0.99


def test_blocks_hold_each_tests_fuel_under_a_wandering_delay():
    pairs = [_trace(3, 1.6, jitter_s=1.0), _trace(4, 1.6, jitter_s=1.0)]
    trs, pws = [a for a, _ in pairs], [b for _, b in pairs]
    errs = {}
    for block_s in (None, 10.0):
        fm = fit_fuel_map(trs, pws, IDLE, meter=(1.6, 1.0), cut_rad_s=1.5 * IDLE, block_s=block_s)
        errs[block_s] = max(abs(e) for e in fm.total_error_rel.values())
    assert errs[10.0] < 0.01
    assert errs[10.0] < errs[None]
