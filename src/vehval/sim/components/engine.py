"""Spark-ignition engine: fuel map, torque limits, inertia, idle/off and fuel cut."""

from __future__ import annotations

import numpy as np

from vehval.numba_cache import njit
from vehval.sim.maps import interp1, interp2


@njit(cache=True)
def fuel_rate(spd_bp, trq_bp, fuel_map, speed, torque):
    """Fuel mass rate [kg/s] of a firing engine at ``speed`` [rad/s] and ``torque`` [N·m]."""
    return max(interp2(spd_bp, trq_bp, fuel_map, speed, max(torque, 0.0)), 0.0)


@njit(cache=True)
def max_torque(spd_bp, tmax, speed):
    """Full-load torque [N·m] at ``speed`` [rad/s] (clamped to the table ends)."""
    return interp1(spd_bp, tmax, speed)


@njit(cache=True)
def warmup_factor(frac, tau_s, t_s):
    """Fuel multiplier of a cold engine ``t_s`` [s] after the start: 1 + frac exp(-t / tau)
    (frac [-] the extra fuel at the start, tau_s [s] the warm-up time constant)."""
    if frac <= 0.0:
        return 1.0
    return 1.0 + frac * np.exp(-t_s / tau_s)
