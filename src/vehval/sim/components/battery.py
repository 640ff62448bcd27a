"""NiMH battery pack: open-circuit voltage and internal resistance over SOC, power limits."""

from __future__ import annotations

import math

from vehval.numba_cache import njit


@njit(cache=True)
def current_from_power(power, ocv, resistance):
    """Terminal current [A] (positive discharging) delivering ``power`` [W] at the terminals.

    Solves ``P = (V_oc - I R) I`` for the smaller root. Beyond the maximum power
    ``V_oc^2 / (4 R)`` the current at maximum power is returned.
    """
    disc = ocv * ocv - 4.0 * resistance * power
    if disc < 0.0:
        return ocv / (2.0 * resistance)
    return (ocv - math.sqrt(disc)) / (2.0 * resistance)


@njit(cache=True)
def terminal_voltage(ocv, resistance, current):
    """Terminal voltage [V] = V_oc - I·R."""
    return ocv - current * resistance
