"""Permanent-magnet machine with inverter (MG1 generator, MG2 traction motor).

Convention: mechanical power ``T·ω`` > 0 when motoring; electrical power drawn from the
DC bus = ``T·ω + loss(ω, T)`` with the loss map >= 0 in every quadrant.
"""

from __future__ import annotations

from vehval.numba_cache import njit
from vehval.sim.maps import interp2


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


