"""Driver: a forward speed-trace follower and the EPA trace-tolerance check.

The demand is a wheel force [N]: a feed-forward through the vehicle model (the inertia
force to go from the present to the next target speed in one step, plus road load) and a
PI on the present speed error (proportional part m_eq / response time) with
conditional-integration anti-windup.
"""

from __future__ import annotations

import numpy as np

from vehval.constants import MPH_M_PER_S as MPH
from vehval.numba_cache import njit


@njit(cache=True)
def driver_force(v, v_now, v_next, dt, mass_eq, road_force, integ, tau, f_min, f_max):
    """Wheel force demand [N].

    Parameters
    ----------
    v : float
        Present vehicle speed [m/s].
    v_now, v_next : float
        Target speed now and one step ahead [m/s].
    dt : float
        Step [s].
    mass_eq : float
        Equivalent mass [kg] of the vehicle model.
    road_force : float
        Road load [N] the feed-forward compensates.
    integ : float
        Present value of the integral term [N].
    tau : float
        Response time [s] of the speed-error correction (proportional gain m_eq / tau,
        never faster than one step).
    f_min, f_max : float
        Bounds of the demand [N].
    """
    f = (mass_eq * (v_next - v_now) / dt + road_force
         + mass_eq * (v_now - v) / max(tau, dt) + integ)
    return min(max(f, f_min), f_max)


@njit(cache=True, inline="always")
def driver_memory(integ, f_real, f_dem, ki, limit, v_target, v, dt):
    """The driver's integral term [N] after one step: conditional integration (anti-windup)
    of the speed error ``v_target - v`` [m/s] with gain ``ki`` [N/(m s)], only while the
    delivered wheel force ``f_real`` [N] follows the demand ``f_dem`` [N], held within
    +-``limit`` [N]."""
    if abs(f_real - f_dem) <= max(100.0, 0.05 * abs(f_dem)):
        integ += ki * (v_target - v) * dt
        integ = min(max(integ, -limit), limit)
    return integ


@njit(cache=True, inline="always")
def band_miss(lo, hi, v):
    """How far [m/s] speed ``v`` lies outside the tolerance band [lo, hi] (0 inside)."""
    return max(lo - v, v - hi, 0.0)


def tolerance_band(time_s: np.ndarray, target_mps: np.ndarray, speed_tol_mps: float,
                   time_tol_s: float) -> tuple[np.ndarray, np.ndarray]:
    """EPA speed-trace band: [min - tol, max + tol] of the target within ±``time_tol_s``.

    Returns
    -------
    lo, hi : ndarray [m/s] on ``time_s``.
    """
    t = np.asarray(time_s, float)
    v = np.asarray(target_mps, float)
    # the target is piecewise linear: its extrema over [t - T, t + T] are at samples inside
    # the window or at the window edges (interpolated)
    lo = np.minimum(np.interp(t - time_tol_s, t, v), np.interp(t + time_tol_s, t, v))
    hi = np.maximum(np.interp(t - time_tol_s, t, v), np.interp(t + time_tol_s, t, v))
    dt = float(np.min(np.diff(t))) if t.size > 1 else 1.0
    n = int(np.ceil(time_tol_s / dt - 1e-9)) if dt > 0 else 0
    for k in range(-n, n + 1):
        idx = np.clip(np.arange(t.size) + k, 0, t.size - 1)
        inside = np.abs(t[idx] - t) <= time_tol_s + 1e-9
        lo = np.where(inside, np.minimum(lo, v[idx]), lo)
        hi = np.where(inside, np.maximum(hi, v[idx]), hi)
    lo = lo - speed_tol_mps
    hi = hi + speed_tol_mps
    return np.maximum(lo, 0.0), hi


def trace_misses(time_s, target_mps, speed_mps, speed_tol_mps: float = 2 * MPH,
                 time_tol_s: float = 1.0) -> dict:
    """Check a driven speed against the EPA tolerance (±2 mph within ±1 s by default).

    Returns
    -------
    dict with ``max_miss_mps`` (largest distance outside the band), ``miss_time_s``
    (time outside the band), ``n_miss`` (samples outside) and ``max_abs_error_mps``.
    """
    lo, hi = tolerance_band(time_s, target_mps, speed_tol_mps, time_tol_s)
    v = np.asarray(speed_mps, float)
    miss = np.maximum(np.maximum(lo - v, v - hi), 0.0)
    dt = float(np.median(np.diff(time_s))) if len(time_s) > 1 else 0.0
    return {"max_miss_mps": float(miss.max(initial=0.0)),
            "n_miss": int(np.count_nonzero(miss > 0)),
            "miss_time_s": float(np.count_nonzero(miss > 0) * dt),
            "max_abs_error_mps": float(np.max(np.abs(v - np.asarray(target_mps, float)),
                                              initial=0.0))}
