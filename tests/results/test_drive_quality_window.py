"""The speed window of the J2951 violation count equals scipy.ndimage's moving maximum and
minimum with ``mode="nearest"`` (the results stage computes it with numpy alone)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from vehval.results.drive_quality import _window_extremes


@pytest.mark.parametrize("n,half", [(1, 1), (2, 1), (3, 10), (25, 10), (500, 10), (37, 3),
                                    (1000, 50)])
def test_window_extremes_equal_scipy_nearest(n, half):
    rng = np.random.default_rng(n * 100 + half)
    v = np.cumsum(rng.normal(size=n))          # a speed-like trace
    v[rng.random(n) < 0.05] = 0.0              # ties and plateaus
    hi, lo = _window_extremes(v, half)
    assert np.array_equal(hi, maximum_filter1d(v, 2 * half + 1, mode="nearest"))
    assert np.array_equal(lo, minimum_filter1d(v, 2 * half + 1, mode="nearest"))
    assert hi.shape == lo.shape == v.shape


def test_window_extremes_see_a_spike_within_the_window_only():
    v = np.zeros(30)
    v[15] = 5.0
    hi, lo = _window_extremes(v, 2)
    assert np.flatnonzero(hi == 5.0).tolist() == [13, 14, 15, 16, 17]
    assert not lo.any()
