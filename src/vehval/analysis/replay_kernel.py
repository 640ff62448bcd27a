"""Compiled part of the engine-rule replay (:mod:`vehval.analysis.replay`), imported only
when a hybrid's rule is fitted or replayed: loading it loads numba."""

from __future__ import annotations

import numpy as np

from vehval.numba_cache import njit


@njit(cache=True)
def lagged_agreement(x, obs, valid, lag_on, lag_off):
    """Share of valid steps where ``x`` delayed by (lag_on at starts, lag_off at stops)
    equals ``obs`` (the compiled equivalent of :func:`vehval.analysis.replay.shift_state` +
    :func:`vehval.analysis.replay.agreement`)."""
    n = x.shape[0]
    hit = 0
    cnt = 0
    for i in range(n):
        if not valid[i]:
            continue
        ja = min(max(i - lag_on, 0), n - 1)
        jb = min(max(i - lag_off, 0), n - 1)
        if lag_on <= lag_off:
            y = x[ja] or x[jb]
        else:
            y = x[ja] and x[jb]
        cnt += 1
        if y == obs[i]:
            hit += 1
    if cnt == 0:
        return np.nan
    return hit / cnt
