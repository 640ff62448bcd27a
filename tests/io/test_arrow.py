"""float64 columns between Arrow and numpy (vehval.io.arrow) give what pyarrow's own
conversions give: nulls as NaN, NaN kept, chunks and slices at any offset."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

from vehval.io.arrow import float_array, float_values


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and bool(
        np.all((a == b) | (np.isnan(a) & np.isnan(b))))


@pytest.mark.parametrize("seed", range(5))
def test_float_values_match_to_numpy_on_chunks_slices_and_nulls(seed):
    rng = np.random.default_rng(seed)
    chunks = []
    for _ in range(int(rng.integers(1, 5))):
        n = int(rng.integers(0, 40))
        v = rng.normal(size=n)
        v[rng.random(n) < 0.1] = np.nan                     # NaN samples (not nulls)
        mask = rng.random(n) < 0.3                          # nulls
        arr = pa.array(v, type=pa.float64(), mask=mask)
        lo = int(rng.integers(0, n + 1))
        chunks.append(arr.slice(lo, int(rng.integers(0, n - lo + 1))))  # bit offsets
    col = pa.chunked_array(chunks, type=pa.float64())
    got = float_values(col)
    assert _same(got, col.to_numpy())
    assert got.flags.writeable
    for chunk in chunks:
        assert _same(float_values(chunk), chunk.to_numpy(zero_copy_only=False))


def test_float_values_of_another_type_use_pyarrow():
    col = pa.chunked_array([pa.array([1, None, 3], type=pa.int64())])
    assert _same(float_values(col), np.array([1.0, np.nan, 3.0]))


@pytest.mark.parametrize("size,n", [(0, 0), (0, 5), (5, 5), (3, 17), (16, 17), (9, 9)])
def test_float_array_matches_pyarrow_array_with_a_mask(size, n):
    v = np.arange(size, dtype=float)
    if size:
        v[0] = np.nan
    full = np.full(n, np.nan)
    full[:size] = v
    mask = np.arange(n) >= size
    want = pa.array(full, type=pa.float64(), mask=mask if size < n else None)
    got = float_array(v, n)
    got.validate(full=True)
    assert got.null_count == want.null_count == n - size
    assert got.is_null().equals(want.is_null())            # NaN != NaN for Array.equals
    assert _same(float_values(got), want.to_numpy(zero_copy_only=False))
