"""Single planetary gear set: engine on the carrier, MG1 on the sun, ring to MG2 and wheels."""

from __future__ import annotations

from vehval.numba_cache import njit


@njit(cache=True)
def sun_speed(carrier_speed, ring_speed, n_sun, n_ring):
    """Sun (MG1) speed [rad/s] from Willis: ω_s N_s = ω_c (N_r + N_s) − ω_r N_r."""
    return (carrier_speed * (n_ring + n_sun) - ring_speed * n_ring) / n_sun


@njit(cache=True)
def willis_residual(ring_speed, sun_speed, carrier_speed, n_sun, n_ring):
    """ω_r N_r + ω_s N_s − ω_c (N_r + N_s) [rad/s · teeth]; zero when the kinematics hold."""
    return ring_speed * n_ring + sun_speed * n_sun - carrier_speed * (n_ring + n_sun)


@njit(cache=True)
def ring_torque_from_engine(engine_torque, n_sun, n_ring):
    """Steady-state torque [N·m] the carrier torque puts on the ring: T_e N_r / (N_r + N_s)."""
    return engine_torque * n_ring / (n_ring + n_sun)


@njit(cache=True)
def sun_torque_from_engine(engine_torque, n_sun, n_ring):
    """Steady-state sun torque [N·m] reacting the engine: −T_e N_s / (N_r + N_s)."""
    return -engine_torque * n_sun / (n_ring + n_sun)
