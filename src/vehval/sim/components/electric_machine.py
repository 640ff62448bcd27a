"""Permanent-magnet machine with inverter (MG1 generator, MG2 traction motor).

Convention: mechanical power ``T·ω`` > 0 when motoring; electrical power drawn from the
DC bus = ``T·ω + loss(ω, T)`` with the loss map >= 0 in every quadrant.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from pydantic import Field, model_validator

from vehval.sim.components.base import RPM, Block, bp_check, table_check
from vehval.sim.maps import interp2


class MachineParams(Block):
    """Electric machine parameters (loss map over speed x torque, limits, inertia)."""

    speed_rpm: list[float]
    torque_nm: list[float]
    loss_w: list[list[float]]
    max_torque_nm: float = Field(gt=0)
    max_power_w: float = Field(gt=0)
    max_speed_rpm: float = Field(gt=0)
    inertia_kg_m2: float = Field(gt=0)

    @model_validator(mode="after")
    def _maps(self):
        bp_check(self.speed_rpm, "speed_rpm")
        bp_check(self.torque_nm, "torque_nm")
        table_check(self.loss_w, len(self.speed_rpm), len(self.torque_nm), "loss_w")
        if np.any(np.asarray(self.loss_w) < 0):
            raise ValueError("'loss_w' must not be negative (losses are always >= 0)")
        return self

    def arrays(self) -> dict[str, np.ndarray]:
        """Loss map in SI: speed [rad/s], torque [N·m], loss [W]."""
        return {"spd": np.asarray(self.speed_rpm, float) * RPM,
                "trq": np.asarray(self.torque_nm, float),
                "loss": np.asarray(self.loss_w, float)}


@njit(cache=True)
def torque_limit(max_torque, max_power, speed):
    """Available torque magnitude [N·m] at ``speed`` [rad/s]: min(T_max, P_max/|ω|)."""
    w = abs(speed)
    if w * max_torque <= max_power:
        return max_torque
    return max_power / w


@njit(cache=True)
def electrical_power(spd_bp, trq_bp, loss_map, speed, torque):
    """DC power drawn [W] (negative when generating) at ``speed`` [rad/s], ``torque`` [N·m]."""
    return torque * speed + max(interp2(spd_bp, trq_bp, loss_map, speed, torque), 0.0)


@njit(cache=True)
def torque_for_power(spd_bp, trq_bp, loss_map, speed, p_target, t_lo, t_hi):
    """Torque in [t_lo, t_hi] whose electrical power is closest to ``p_target`` [W] from below.

    Electrical power rises with torque at a positive speed; bisection (30 halvings).
    Returns ``t_hi`` when even ``t_hi`` draws no more than ``p_target``, ``t_lo`` when
    even ``t_lo`` draws more.
    """
    if electrical_power(spd_bp, trq_bp, loss_map, speed, t_hi) <= p_target:
        return t_hi
    if electrical_power(spd_bp, trq_bp, loss_map, speed, t_lo) > p_target:
        return t_lo
    a, b = t_lo, t_hi
    for _ in range(30):
        m = 0.5 * (a + b)
        if electrical_power(spd_bp, trq_bp, loss_map, speed, m) > p_target:
            b = m
        else:
            a = m
    return a


