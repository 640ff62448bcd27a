"""Look-up tables for the simulator: validation (Python) and interpolation (numba).

Maps are plain float arrays: 1-D curves over one breakpoint vector and 2-D grids over two
(row breakpoints x column breakpoints). Interpolation is linear (1-D) or bilinear (2-D)
and clamps at the table edges, so the compiled time loop never extrapolates.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
from numba import njit

from vehval.errors import ConfigError


def check_breakpoints(values: Sequence[float], key: str, where: str = "") -> np.ndarray:
    """Return ``values`` as a float array after checking it is a strictly increasing vector.

    Parameters
    ----------
    values : sequence of float
        Breakpoints.
    key : str
        Dotted parameter key, used in the error message.
    where : str
        File name (or other context) for the error message.

    Raises
    ------
    ConfigError
        If the vector has fewer than 2 entries, is not finite or not strictly increasing.
    """
    arr = np.asarray(values, dtype=float)
    loc = f" in {where}" if where else ""
    if arr.ndim != 1 or arr.size < 2:
        raise ConfigError(f"'{key}'{loc}: breakpoints must be a list of at least 2 numbers")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f"'{key}'{loc}: breakpoints must be finite numbers")
    bad = np.nonzero(np.diff(arr) <= 0)[0]
    if bad.size:
        i = int(bad[0])
        raise ConfigError(
            f"'{key}'{loc}: breakpoints must be strictly increasing, but entry {i + 1} "
            f"({arr[i + 1]:g}) follows {arr[i]:g}; sort the breakpoints and the map with them")
    return arr


def check_table(values, shape: tuple[int, ...], key: str, where: str = "") -> np.ndarray:
    """Return ``values`` as a finite float array of the given ``shape`` (ConfigError otherwise)."""
    loc = f" in {where}" if where else ""
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"'{key}'{loc}: table must be numeric ({exc})") from None
    if arr.shape != tuple(shape):
        raise ConfigError(f"'{key}'{loc}: table has shape {arr.shape}, expected {tuple(shape)} "
                          "(rows = first breakpoint vector, columns = second)")
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f"'{key}'{loc}: table must contain finite numbers only")
    return arr


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


def bilinear(xb: np.ndarray, yb: np.ndarray, z: np.ndarray, x: np.ndarray, y: np.ndarray):
    """Vectorised clamped bilinear interpolation of ``z[x, y]`` (same rule as interp2).

    Queries outside the breakpoints are clamped to the edge of the table.
    """
    x = np.clip(x, xb[0], xb[-1])
    y = np.clip(y, yb[0], yb[-1])
    i = np.clip(np.searchsorted(xb, x, side="right") - 1, 0, xb.size - 2)
    j = np.clip(np.searchsorted(yb, y, side="right") - 1, 0, yb.size - 2)
    wx = (x - xb[i]) / (xb[i + 1] - xb[i])
    wy = (y - yb[j]) / (yb[j + 1] - yb[j])
    a = z[i, j] + wy * (z[i, j + 1] - z[i, j])
    b = z[i + 1, j] + wy * (z[i + 1, j + 1] - z[i + 1, j])
    return a + wx * (b - a)
