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


@njit(cache=True, inline="always")
def longitudinal_step(v0, f_pt, f_dem, brake_max, rl_a, rl_b, rl_c, m_eq, dt):
    """One step of the car's motion: the friction brake covers what the powertrain force
    ``f_pt`` [N] does not of a negative demand ``f_dem`` [N] (at most ``brake_max`` [N]),
    road load at ``v0`` [m/s], speed at the step's end [m/s] (explicit Euler, equivalent mass
    ``m_eq`` [kg]). A car that stops within the step: brake, then road load, take only what
    stops it. Returns ``(v1, f_brk, fl)``."""
    f_brk = min(max(f_pt - f_dem, 0.0), brake_max) if f_dem < 0.0 else 0.0
    fl = road_load(v0, rl_a, rl_b, rl_c)
    v1 = v0 + dt * (f_pt - f_brk - fl) / m_eq
    if v1 < 0.0:
        v1 = 0.0
        f_brk = f_pt - fl + v0 * m_eq / dt
        if f_brk < 0.0:
            fl += f_brk
            f_brk = 0.0
    return v1, f_brk, fl
