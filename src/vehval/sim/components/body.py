"""Vehicle body on the chassis dynamometer: test mass and road load F = A + B v + C v^2."""

from __future__ import annotations

from vehval.numba_cache import njit


@njit(cache=True)
def road_load(speed, a, b, c):
    """Road-load force [N] at ``speed`` [m/s] >= 0: A + B v + C v^2 (zero at standstill)."""
    if speed <= 0.0:
        return 0.0
    return a + b * speed + c * speed * speed


def equivalent_mass(mass_kg: float, rotating_inertia_kg_m2: float, wheel_radius_m: float) -> float:
    """Mass [kg] including rotating inertia referred to the wheel: m + J / r^2 (eq. 5)."""
    return mass_kg + rotating_inertia_kg_m2 / wheel_radius_m ** 2
