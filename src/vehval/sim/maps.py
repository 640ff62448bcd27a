"""Look-up tables in the compiled time loop: linear and bilinear interpolation (numba).

Maps are plain float arrays: 1-D curves over one breakpoint vector and 2-D grids over two
(row breakpoints x column breakpoints). Interpolation is linear (1-D) or bilinear (2-D)
and clamps at the table edges, so the compiled time loop never extrapolates.
"""

from __future__ import annotations

from vehval.numba_cache import njit


@njit(cache=True)
def _locate(bp, x):
    """Index i and weight w such that x ~ bp[i] + w (bp[i+1] - bp[i]), clamped to the table."""
    n = bp.shape[0]
    if x <= bp[0]:
        return 0, 0.0
    if x >= bp[n - 1]:
        return n - 2, 1.0
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if bp[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo, (x - bp[lo]) / (bp[lo + 1] - bp[lo])


@njit(cache=True)
def interp1(bp, table, x):
    """Linear interpolation of ``table`` over breakpoints ``bp`` at ``x``, clamped at the ends."""
    i, w = _locate(bp, x)
    return table[i] + w * (table[i + 1] - table[i])


@njit(cache=True)
def interp2(bp_row, bp_col, table, x_row, x_col):
    """Bilinear interpolation of a 2-D ``table[row, col]`` at (``x_row``, ``x_col``), clamped."""
    i, wi = _locate(bp_row, x_row)
    j, wj = _locate(bp_col, x_col)
    a = table[i, j] + wj * (table[i, j + 1] - table[i, j])
    b = table[i + 1, j] + wj * (table[i + 1, j + 1] - table[i + 1, j])
    return a + wi * (b - a)
