"""Electric energy figures of a battery-electric test (SAE J1634): the one home of MPGe.

A BEV's energy consumption is stated per distance (Wh/mi, kWh/100 mi, kWh/100 km) and, on
US labels and the EPA Test Car Lists, as miles per gallon of gasoline equivalent (MPGe):
distance over AC (wall) energy, one gallon equivalent being
:data:`KWH_PER_GALLON_EQUIVALENT` kWh (EPA/DOE, 65 FR 36986: 33.705 kWh per gallon). DC
(battery terminal) energy becomes AC energy through the charger efficiency (wall ->
battery): ``E_AC = E_DC / eta_charger``.
"""

from __future__ import annotations

import math

from vehval.constants import KWH_J, MILE_M
from vehval.errors import VehvalError

#: kWh of electricity equivalent to one US gallon of gasoline (EPA/DOE MPGe basis).
KWH_PER_GALLON_EQUIVALENT = 33.705
#: Joules per gallon equivalent [J].
GALLON_EQUIVALENT_J = KWH_PER_GALLON_EQUIVALENT * KWH_J


def ac_energy_j(dc_energy_j: float, charger_efficiency: float) -> float:
    """AC (wall) energy [J] that recharges ``dc_energy_j`` [J] through a charger of
    efficiency ``charger_efficiency`` (wall -> battery, 0 < eta <= 1)."""
    if not 0.0 < charger_efficiency <= 1.0:
        raise VehvalError(f"charger efficiency {charger_efficiency:g} is outside (0, 1]")
    return dc_energy_j / charger_efficiency


def wh_per_mile(energy_j: float, distance_m: float) -> float:
    """Consumption [Wh/mi] of ``energy_j`` [J] over ``distance_m`` [m] (NaN without distance)."""
    if distance_m <= 0.0:
        return math.nan
    return energy_j / 3600.0 / (distance_m / MILE_M)


def kwh_per_100km(energy_j: float, distance_m: float) -> float:
    """Consumption [kWh/100 km] (NaN without distance)."""
    if distance_m <= 0.0:
        return math.nan
    return energy_j / KWH_J / (distance_m / 1e5)


def kwh_per_100mi(energy_j: float, distance_m: float) -> float:
    """Consumption [kWh/100 mi] (NaN without distance)."""
    if distance_m <= 0.0:
        return math.nan
    return energy_j / KWH_J / (distance_m / (100.0 * MILE_M))


def mpge(ac_energy_j_: float, distance_m: float) -> float:
    """Miles per gallon equivalent of AC energy [J] over distance [m] (inf without energy)."""
    if ac_energy_j_ <= 0.0:
        return math.inf
    return (distance_m / MILE_M) / (ac_energy_j_ / GALLON_EQUIVALENT_J)


def kwh_per_100mi_from_mpge(value: float) -> float:
    """kWh/100 mi of an MPGe figure (the inverse of :func:`mpge` per 100 mi)."""
    if value <= 0.0:
        raise VehvalError(f"MPGe {value:g} must be positive")
    return 100.0 * KWH_PER_GALLON_EQUIVALENT / value


def mpge_from_kwh_per_100mi(value: float) -> float:
    """MPGe of a consumption in kWh/100 mi."""
    if value <= 0.0:
        raise VehvalError(f"consumption {value:g} kWh/100 mi must be positive")
    return 100.0 * KWH_PER_GALLON_EQUIVALENT / value
