"""Maps of a vehicle definition: breakpoint and table checks, vectorised interpolation,
and the engine's best-efficiency line derived from its fuel map.

Maps are plain float arrays: 1-D curves over one breakpoint vector and 2-D grids over two
(row breakpoints x column breakpoints). Interpolation is bilinear and clamps at the table
edges (the same rule as the compiled look-ups in :mod:`vehval.sim.maps`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np

from vehval.constants import BRAKE_EFFICIENCY_RANGE
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


# ------------------------------------------------------------------ brake efficiency
def peak_brake_efficiency_of_map(speed_rpm, torque_nm, fuel_g_per_s, max_torque_nm,
                                 lhv_j_per_kg: float, idle_speed_rpm: float | None = None
                                 ) -> tuple[float, float, float]:
    """Peak brake efficiency of a fuel map where the engine runs fired.

    The one rule: brake power / fuel power over the map's grid points with torque above
    zero and within the full-load curve (1e-9 N·m tolerance), a positive fuel rate and, when
    ``idle_speed_rpm`` is given, a speed at or above idle.

    Parameters
    ----------
    speed_rpm, torque_nm : sequence of float
        Map breakpoints [rpm], [N·m].
    fuel_g_per_s : 2-D sequence
        Fuel rate over speed x torque [g/s].
    max_torque_nm : sequence of float
        Full-load torque at each map speed [N·m].
    lhv_j_per_kg : float
        Fuel lower heating value [J/kg].
    idle_speed_rpm : float, optional
        Lowest speed counted [rpm].

    Returns
    -------
    (efficiency [-], speed [rpm], torque [N·m]); NaNs when no point is fired.
    """
    spd = np.asarray(speed_rpm, float)
    trq = np.asarray(torque_nm, float)
    fuel = np.asarray(fuel_g_per_s, float) * 1e-3
    tmax = np.asarray(max_torque_nm, float)
    power = spd[:, None] * RPM * trq[None, :]
    ok = (trq[None, :] > 0) & (trq[None, :] <= tmax[:, None] + 1e-9) & (fuel > 0)
    if idle_speed_rpm is not None:
        ok &= spd[:, None] >= idle_speed_rpm
    eta = np.where(ok, power / np.where(ok, fuel, 1.0) / lhv_j_per_kg, -np.inf)
    i, j = np.unravel_index(int(np.argmax(eta)), eta.shape)
    if not np.isfinite(eta[i, j]):
        return float("nan"), float("nan"), float("nan")
    return float(eta[i, j]), float(spd[i]), float(trq[j])


def peak_brake_efficiency(engine: EngineParams) -> tuple[float, float, float]:
    """Peak brake efficiency of an engine's fuel map from its idle speed up (the rule of
    :func:`peak_brake_efficiency_of_map`): (efficiency [-], speed [rpm], torque [N·m])."""
    return peak_brake_efficiency_of_map(engine.speed_rpm, engine.torque_nm,
                                        engine.fuel_rate_g_per_s, engine.max_torque_nm,
                                        engine.fuel_lhv_j_per_kg, engine.idle_speed_rpm)


def best_line_efficiency(engine: EngineParams, line=None) -> float:
    """Highest brake efficiency [-] on the engine's best-efficiency line (the map
    interpolated bilinearly along :func:`best_efficiency_line`, or ``line`` = (power [W],
    speed [rad/s], torque [N·m]) when already computed). The efficiency the simulator's
    controller and charge correction count on; NaN when the line burns no fuel."""
    p, w, t = best_efficiency_line(engine) if line is None else line
    a = engine.arrays()
    fuel = bilinear(a["spd"], a["trq"], a["fuel"], w, t)
    ok = (p > 0) & (fuel > 0)
    if not ok.any():
        return float("nan")
    return float(np.max(p[ok] / (fuel[ok] * engine.fuel_lhv_j_per_kg)))


def brake_efficiency_plausible(eta: float) -> bool:
    """Whether a peak brake efficiency [-] lies in the band of road engines,
    :data:`vehval.constants.BRAKE_EFFICIENCY_RANGE` (a value outside, or NaN, points at a
    unit or mapping mistake in the fuel or at a map that does not describe the car)."""
    lo, hi = BRAKE_EFFICIENCY_RANGE
    return bool(lo <= eta <= hi)
