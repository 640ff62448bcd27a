"""Spark-ignition engine: fuel map, torque limits, inertia, idle/off and fuel cut."""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import Field, model_validator

from vehval.sim.components.base import RPM, Block, bp_check, table_check
from vehval.sim.maps import bilinear, interp1, interp2


class EngineParams(Block):
    """Engine parameters. Speeds in rpm in the file, converted to rad/s by :meth:`arrays`."""

    speed_rpm: list[float]
    torque_nm: list[float]
    fuel_rate_g_per_s: list[list[float]]
    max_torque_nm: list[float]
    max_power_w: float = Field(gt=0)
    max_speed_rpm: float = Field(gt=0)
    idle_speed_rpm: float = Field(gt=0)
    fire_speed_rpm: float = Field(gt=0)
    motoring_torque_nm: float = Field(ge=0)
    inertia_kg_m2: float = Field(gt=0)
    fuel_density_kg_per_m3: float = Field(gt=0)
    fuel_lhv_j_per_kg: float = Field(gt=0)

    @model_validator(mode="after")
    def _maps(self):
        bp_check(self.speed_rpm, "speed_rpm")
        bp_check(self.torque_nm, "torque_nm")
        table_check(self.fuel_rate_g_per_s, len(self.speed_rpm), len(self.torque_nm),
                    "fuel_rate_g_per_s")
        table_check(self.max_torque_nm, len(self.speed_rpm), None, "max_torque_nm")
        if np.any(np.asarray(self.fuel_rate_g_per_s) < 0):
            raise ValueError("'fuel_rate_g_per_s' must not be negative")
        if not self.idle_speed_rpm < self.max_speed_rpm:
            raise ValueError("'idle_speed_rpm' must be below 'max_speed_rpm'")
        return self

    def arrays(self) -> dict[str, np.ndarray]:
        """Maps in SI: speed [rad/s], torque [N·m], fuel rate [kg/s], max torque [N·m]."""
        return {
            "spd": np.asarray(self.speed_rpm, float) * RPM,
            "trq": np.asarray(self.torque_nm, float),
            "fuel": np.asarray(self.fuel_rate_g_per_s, float) * 1e-3,
            "tmax": np.asarray(self.max_torque_nm, float),
        }


@njit(cache=True)
def fuel_rate(spd_bp, trq_bp, fuel_map, speed, torque):
    """Fuel mass rate [kg/s] of a firing engine at ``speed`` [rad/s] and ``torque`` [N·m]."""
    return max(interp2(spd_bp, trq_bp, fuel_map, speed, max(torque, 0.0)), 0.0)


@njit(cache=True)
def max_torque(spd_bp, tmax, speed):
    """Full-load torque [N·m] at ``speed`` [rad/s] (clamped to the table ends)."""
    return interp1(spd_bp, tmax, speed)


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


