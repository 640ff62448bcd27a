"""Min/max decimation of time traces for display.

A long trace (10 Hz over 1,500 s is 15,000 samples per channel) is reduced to at most two
samples per display bucket: the minimum and the maximum of the bucket, in time order. The
drawn envelope is then identical to the full-resolution trace at screen resolution, and no
extreme is ever dropped: the global minimum and maximum, and the minimum and maximum of every
bucket, are in the output. Gaps (NaN samples) are kept as NaN points so that lines break
where the data does.
"""

from __future__ import annotations

import numpy as np

#: Display buckets of a time trace: about one per pixel of a report plot on a wide screen
#: (the data files keep every sample).
DEFAULT_BUCKETS = 1200


def bucket_index(time: np.ndarray, n_buckets: int) -> np.ndarray:
    """Bucket number of every sample for ``n_buckets`` equal-width time buckets.

    Parameters
    ----------
    time : numpy.ndarray
        Sample times [s], non-decreasing.
    n_buckets : int
        Number of buckets over ``[time[0], time[-1]]`` (think: horizontal pixels).

    Returns
    -------
    numpy.ndarray
        Integer bucket of each sample, in ``0 .. n_buckets - 1``, non-decreasing.
    """
    t = np.asarray(time, float)
    if t.size == 0:
        return np.zeros(0, dtype=np.int64)
    span = float(t[-1] - t[0])
    if not np.isfinite(span) or span <= 0.0:
        return np.zeros(t.size, dtype=np.int64)
    idx = np.floor((t - t[0]) / span * n_buckets).astype(np.int64)
    return np.clip(idx, 0, n_buckets - 1)


def minmax_indices(time: np.ndarray, values: np.ndarray,
                   n_buckets: int = DEFAULT_BUCKETS) -> np.ndarray:
    """Indices of the samples kept by min/max decimation, sorted.

    Every bucket keeps the index of its first minimum, of its first maximum and of its
    first NaN sample (so a gap stays visible); the first and last sample are always kept.
    When the trace has at most ``2 * n_buckets`` samples every index is returned.

    Parameters
    ----------
    time : numpy.ndarray
        Sample times [s], non-decreasing.
    values : numpy.ndarray
        Samples (any unit; NaN marks missing data).
    n_buckets : int
        Number of display buckets.

    Returns
    -------
    numpy.ndarray
        Sorted unique integer indices into ``values``.
    """
    y = np.asarray(values, float)
    n = y.size
    if n_buckets < 1:
        raise ValueError("n_buckets must be at least 1")
    if n <= 2 * n_buckets:
        return np.arange(n)
    b = bucket_index(time, n_buckets)
    starts = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])
    nan = np.isnan(y)
    lo = np.where(nan, np.inf, y)
    hi = np.where(nan, -np.inf, y)
    bmin = np.minimum.reduceat(lo, starts)
    bmax = np.maximum.reduceat(hi, starts)
    seg = np.repeat(np.arange(starts.size), np.diff(np.r_[starts, n]))
    keep = [starts[:1], np.array([n - 1])]
    for mask in (lo == bmin[seg], hi == bmax[seg], nan):
        # the first flagged sample of each bucket (buckets with no finite sample flag all
        # samples with inf == inf, harmless: they are NaN and kept once as a gap marker)
        hits = np.flatnonzero(mask)
        if hits.size:
            _, first = np.unique(seg[hits], return_index=True)
            keep.append(hits[first])
    return np.unique(np.concatenate(keep))


def decimate_minmax(time: np.ndarray, values: np.ndarray, n_buckets: int = DEFAULT_BUCKETS,
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Decimate a trace for display, keeping the minimum and maximum of every bucket.

    Parameters
    ----------
    time : numpy.ndarray
        Sample times [s], non-decreasing.
    values : numpy.ndarray
        Samples (NaN marks missing data).
    n_buckets : int
        Number of display buckets (default 1,200: about one per pixel of a report plot).

    Returns
    -------
    time, values : numpy.ndarray
        The kept samples, in time order (at most ``3 * n_buckets + 2``; usually
        ``2 * n_buckets``).
    """
    t = np.asarray(time, float)
    y = np.asarray(values, float)
    idx = minmax_indices(t, y, n_buckets)
    return t[idx], y[idx]
