"""Min/max decimation keeps every extreme (global and per display bucket) and every gap."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vehval.report.decimate import bucket_index, decimate_minmax, minmax_indices


def _check_extremes(t, y, n_buckets):
    td, yd = decimate_minmax(t, y, n_buckets)
    assert np.all(np.diff(td) >= 0), "decimated trace must stay in time order"
    # exact equality: samples are copied, not averaged
    assert np.nanmin(yd) == np.nanmin(y) and np.nanmax(yd) == np.nanmax(y)
    b_full, b_dec = bucket_index(t, n_buckets), None
    idx = minmax_indices(t, y, n_buckets)
    b_dec = b_full[idx]
    for b in np.unique(b_full):
        seg = y[b_full == b]
        kept = y[idx][b_dec == b]
        if np.isfinite(seg).any():
            assert np.nanmin(kept) == np.nanmin(seg) and np.nanmax(kept) == np.nanmax(seg)
        if np.isnan(seg).any():
            assert np.isnan(kept).any(), "a gap in a bucket must stay visible"
    return td, yd


def test_long_trace_is_reduced_and_keeps_extremes():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 1500.0, 0.1)                     # 15,000 samples (10 Hz, 1,500 s)
    y = np.cumsum(rng.normal(size=t.size))
    y[1234] = 1e3                                       # a single-sample spike must survive
    y[9876] = -1e3
    td, yd = _check_extremes(t, y, 2000)
    assert td.size <= 2 * 2000 + 2
    assert 1e3 in yd and -1e3 in yd
    assert td[0] == t[0] and td[-1] == t[-1]


def test_nan_gaps_survive():
    t = np.arange(0.0, 1000.0, 0.05)
    y = np.sin(t)
    y[5000:5100] = np.nan
    y[15000:] = np.nan                                  # whole trailing buckets empty
    _, yd = _check_extremes(t, y, 500)
    assert np.isnan(yd).sum() >= 2


def test_short_trace_untouched():
    t = np.arange(10.0)
    y = np.arange(10.0) ** 2
    td, yd = decimate_minmax(t, y, 2000)
    np.testing.assert_array_equal(td, t)
    np.testing.assert_array_equal(yd, y)


def test_constant_time_and_single_bucket():
    t = np.zeros(50)
    y = np.linspace(-1, 1, 50)
    td, yd = decimate_minmax(t, y, 10)
    assert yd.min() == -1 and yd.max() == 1


@settings(max_examples=60, deadline=None)
@given(st.lists(st.one_of(st.floats(-1e6, 1e6), st.just(float("nan"))), min_size=1, max_size=400),
       st.integers(1, 50))
def test_property_extremes_kept(values, n_buckets):
    y = np.asarray(values, float)
    t = np.cumsum(np.ones(y.size) * 0.1)
    if np.isfinite(y).any():
        _check_extremes(t, y, n_buckets)
    else:
        _, yd = decimate_minmax(t, y, n_buckets)
        assert np.isnan(yd).all()
