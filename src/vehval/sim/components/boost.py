"""Boost converter between the battery (201.6 V nominal) and the high-voltage bus (<= 500 V)."""

from __future__ import annotations

from vehval.numba_cache import njit


@njit(cache=True)
def battery_side_power(bus_power, efficiency):
    """Battery-side power [W] for a bus power [W] (losses on the input side when boosting)."""
    if bus_power >= 0.0:
        return bus_power / efficiency
    return bus_power * efficiency


@njit(cache=True)
def output_voltage(v_batt, speed_frac, v_min, v_max):
    """Bus voltage [V]: from max(v_batt, v_min) at standstill rising linearly to v_max.

    ``speed_frac`` is the larger machine speed as a fraction of its full-voltage speed.
    """
    lo = max(v_batt, v_min)
    f = min(max(speed_frac, 0.0), 1.0)
    return lo + f * (max(v_max, lo) - lo)
