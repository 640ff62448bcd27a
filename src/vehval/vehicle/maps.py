"""Maps of a vehicle definition: breakpoint and table checks, vectorised interpolation,
and the engine's best-efficiency line derived from its fuel map.

Maps are plain float arrays: 1-D curves over one breakpoint vector and 2-D grids over two
(row breakpoints x column breakpoints). Interpolation is bilinear and clamps at the table
edges (the same rule as the compiled look-ups in :mod:`vehval.sim.maps`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.errors import ConfigError

if TYPE_CHECKING:
    from vehval.vehicle.components import EngineParams


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


def best_efficiency_line(p: EngineParams, n_power: int = 121, n_speed: int = 400):
    """Operating line of least fuel per power, computed from the fuel map.

    For each engine power on a uniform grid from 0 to the maximum power, every speed on a
    fine grid between idle and maximum speed is tried with torque = power / speed (within
    the full-load curve); the speed of least fuel rate is kept. The line is then made
    non-decreasing in speed so that a rising power never asks the engine to slow down.

    Returns
    -------
    power : ndarray [W], speed : ndarray [rad/s], torque : ndarray [N·m]
    """
    a = p.arrays()
    w_lo, w_hi = p.idle_speed_rpm * RPM, p.max_speed_rpm * RPM
    speeds = np.linspace(w_lo, w_hi, n_speed)
    tmax = np.interp(speeds, a["spd"], a["tmax"])
    pmax = min(p.max_power_w, float(np.max(speeds * tmax)))
    power = np.linspace(0.0, pmax, n_power)
    # bilinear fuel rate on the (power x speed) grid, torque = power / speed
    trq = power[:, None] / speeds[None, :]
    fr = bilinear(a["spd"], a["trq"], a["fuel"], np.broadcast_to(speeds, trq.shape), trq)
    fr = np.where(trq <= tmax[None, :] + 1e-9, fr, np.inf)
    best = np.where(np.isfinite(fr).any(axis=1), speeds[np.argmin(fr, axis=1)], w_hi)
    best[0] = w_lo
    best = np.maximum.accumulate(best)
    return power, best, power / best
