"""Powertrain relations as pure functions (equations (1)-(7) of docs/DESIGN.md and friends).

Every function works on floats or numpy arrays (broadcasting) and uses SI units: shaft
speeds [rad/s], vehicle speed [m/s], torque [N·m], force [N], power [W], mass [kg].
The power-split layout is the Prius THS: engine on the planetary carrier, generator (MG1)
on the sun gear, traction motor (MG2) on the ring gear, ring turning at the final-drive
ratio times the wheel speed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from vehval.integrals import cumulative


def wheel_speed_from_vehicle(veh_spd: ArrayLike, wheel_radius_m: float) -> np.ndarray:
    """Wheel speed [rad/s] from vehicle speed ``veh_spd`` [m/s] and radius [m]."""
    return np.asarray(veh_spd, float) / wheel_radius_m


def final_drive_input_speed(whl_spd: ArrayLike, fd_ratio: float) -> np.ndarray:
    """Final-drive input (ring gear) speed [rad/s] = ``fd_ratio`` × wheel speed [rad/s]."""
    return np.asarray(whl_spd, float) * fd_ratio


def willis_gen_speed(eng_spd: ArrayLike, mot_spd: ArrayLike, ring_teeth: float,
                     sun_teeth: float) -> np.ndarray:
    """Generator (sun) speed [rad/s] from the Willis equation (3).

    ``ω_mot·Nr + ω_gen·Ns = ω_eng·(Nr + Ns)`` solved for ``ω_gen``.

    Parameters
    ----------
    eng_spd : array_like
        Engine (carrier) speed [rad/s].
    mot_spd : array_like
        Motor (ring) speed [rad/s].
    ring_teeth, sun_teeth : float
        Tooth counts Nr, Ns [-].
    """
    e, m = np.asarray(eng_spd, float), np.asarray(mot_spd, float)
    return (e * (ring_teeth + sun_teeth) - m * ring_teeth) / sun_teeth


def willis_mot_speed(eng_spd: ArrayLike, gen_spd: ArrayLike, ring_teeth: float,
                     sun_teeth: float) -> np.ndarray:
    """Motor (ring) speed [rad/s] from the Willis equation (3)."""
    e, g = np.asarray(eng_spd, float), np.asarray(gen_spd, float)
    return (e * (ring_teeth + sun_teeth) - g * sun_teeth) / ring_teeth


def willis_eng_speed(mot_spd: ArrayLike, gen_spd: ArrayLike, ring_teeth: float,
                     sun_teeth: float) -> np.ndarray:
    """Engine (carrier) speed [rad/s] from the Willis equation (3)."""
    m, g = np.asarray(mot_spd, float), np.asarray(gen_spd, float)
    return (m * ring_teeth + g * sun_teeth) / (ring_teeth + sun_teeth)


def ring_torque(eng_trq: ArrayLike, ring_teeth: float, sun_teeth: float) -> np.ndarray:
    """Torque the engine passes to the ring gear [N·m], equation (2): T_eng·Nr/(Nr+Ns)."""
    return np.asarray(eng_trq, float) * ring_teeth / (ring_teeth + sun_teeth)


def sun_torque(eng_trq: ArrayLike, ring_teeth: float, sun_teeth: float) -> np.ndarray:
    """Generator torque that holds the sun gear in steady state [N·m]: −T_eng·Ns/(Nr+Ns)."""
    return -np.asarray(eng_trq, float) * sun_teeth / (ring_teeth + sun_teeth)


def motor_torque(whl_trq: ArrayLike, fd_ratio: float, ring_trq: ArrayLike) -> np.ndarray:
    """Motor (MG2) torque [N·m], equation (1): T_wheel/ratio_fd − T_ring."""
    return np.asarray(whl_trq, float) / fd_ratio - np.asarray(ring_trq, float)


def wheel_torque(veh_frc: ArrayLike, wheel_radius_m: float) -> np.ndarray:
    """Wheel torque [N·m] from the tractive force at the tyre [N], equation (4)."""
    return np.asarray(veh_frc, float) * wheel_radius_m


def vehicle_force_out(mass_kg: float, veh_acc: ArrayLike, inertia_fraction: float = 0.0) -> np.ndarray:
    """Force accelerating the vehicle [N], equation (5): m·a·(1 + inertia fraction)."""
    return mass_kg * np.asarray(veh_acc, float) * (1.0 + inertia_fraction)


def road_load(veh_spd: ArrayLike, a_n: float, b_n_per_mps: float, c_n_per_mps2: float,
              standstill_mps: float = 0.0) -> np.ndarray:
    """Road-load force [N], equation (7): A + B·v + C·v².

    Parameters
    ----------
    veh_spd : array_like
        Vehicle speed [m/s].
    a_n, b_n_per_mps, c_n_per_mps2 : float
        Coefficients A [N], B [N/(m/s)], C [N/(m/s)²].
    standstill_mps : float
        Below this speed [m/s] the load is 0 (a dyno applies no load at rest).
    """
    v = np.asarray(veh_spd, float)
    f = a_n + b_n_per_mps * v + c_n_per_mps2 * v * v
    return np.where(np.abs(v) > standstill_mps, f, 0.0) if standstill_mps > 0 else f


def vehicle_force_in(force_out: ArrayLike, force_loss: ArrayLike) -> np.ndarray:
    """Total tractive force at the tyre [N], equation (6): F_out + F_loss."""
    return np.asarray(force_out, float) + np.asarray(force_loss, float)


def power(effort: ArrayLike, flow: ArrayLike) -> np.ndarray:
    """Power [W] = effort × flow (torque [N·m] × speed [rad/s], force × speed, V × A)."""
    return np.asarray(effort, float) * np.asarray(flow, float)


def fuel_power(fuel_rate: ArrayLike, lhv_j_per_kg: float) -> np.ndarray:
    """Fuel chemical power [W] = mass rate [kg/s] × lower heating value [J/kg]."""
    return np.asarray(fuel_rate, float) * lhv_j_per_kg


def deriv(time: ArrayLike, x: ArrayLike) -> np.ndarray:
    """Time derivative [unit/s] by central differences (one-sided at the ends)."""
    t, v = np.asarray(time, float), np.asarray(x, float)
    if v.size < 2:
        return np.full(v.shape, np.nan)
    return np.gradient(v, t)


def cumint(time: ArrayLike, x: ArrayLike) -> np.ndarray:
    """Cumulative trapezoidal integral [unit·s] from the first sample, gaps bridged
    (:func:`vehval.integrals.cumulative`)."""
    return cumulative(time, x)


def smooth(time: ArrayLike, x: ArrayLike, window_s: float) -> np.ndarray:
    """Centred moving average over ``window_s`` [s] on a uniform grid (NaN-aware)."""
    t, v = np.asarray(time, float), np.asarray(x, float)
    if v.size < 3 or window_s <= 0:
        return v.copy()
    dt = float(np.median(np.diff(t)))
    n = max(1, int(round(window_s / dt)))
    if n <= 1:
        return v.copy()
    ok = np.isfinite(v)
    n = min(n, v.size)                   # a wider window adds nothing but cost
    if n <= 256:
        k = np.ones(n)
        num = np.convolve(np.where(ok, v, 0.0), k, mode="same")
        den = np.convolve(ok.astype(float), k, mode="same")
    else:                                # O(N) running sums, same alignment as "same"
        num, den = _window_sum(np.where(ok, v, 0.0), n), _window_sum(ok.astype(float), n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(ok & (den > 0), num / den, np.nan)


def _window_sum(a: np.ndarray, n: int) -> np.ndarray:
    """``np.convolve(a, ones(n), mode="same")`` in O(N) with cumulative sums."""
    c = np.concatenate(([0.0], np.cumsum(a)))
    i = np.arange(a.size)
    hi = np.minimum(i + (n - 1) // 2, a.size - 1) + 1
    lo = np.maximum(i + (n - 1) // 2 - n + 1, 0)
    return c[hi] - c[lo]


def efficiency(out: ArrayLike, inp: ArrayLike, min_abs: float = 0.0) -> np.ndarray:
    """Efficiency out/in [-]; NaN where |in| ≤ ``min_abs`` (undefined at no load)."""
    o, i = np.asarray(out, float), np.asarray(inp, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(np.abs(i) > max(min_abs, 0.0) if min_abs > 0 else i != 0, o / i, np.nan)
