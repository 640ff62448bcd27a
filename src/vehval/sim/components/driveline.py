"""Final drive, wheels and friction brakes."""

from __future__ import annotations

from vehval.numba_cache import njit


@njit(cache=True)
def wheel_force_from_ring_torque(ring_torque, ratio, radius, efficiency):
    """Tractive force [N] at the tyre for a final-drive input torque [N·m] (loss on the driven side)."""
    f = ring_torque * ratio / radius
    if f >= 0.0:
        return f * efficiency
    return f / efficiency


@njit(cache=True)
def ring_speed_from_vehicle(speed, ratio, radius):
    """Ring gear (and MG2) speed [rad/s] from vehicle speed [m/s]."""
    return speed * ratio / radius
