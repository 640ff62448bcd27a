"""Final drive, wheels and friction brakes."""

from __future__ import annotations

from numba import njit
from pydantic import Field

from vehval.sim.components.base import Block


class DrivelineParams(Block):
    """Final drive, wheel and brake parameters."""

    final_drive_ratio: float = Field(gt=0)
    final_drive_efficiency: float = Field(gt=0, le=1)
    wheel_radius_m: float = Field(gt=0)
    wheel_inertia_kg_m2: float = Field(ge=0)
    brake_max_force_n: float = Field(gt=0)


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
