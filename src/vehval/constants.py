"""Physical constants and unit conversions used across the package: one home for each figure.

Data inside vehval is SI (m, s, kg, J, W, rad/s); these factors convert at the edges
(display, regulatory results). Fuel properties are data, not constants: see the fuel table.
"""

from __future__ import annotations

import math

#: Standard gravity [m/s^2] (CGPM 1901).
GRAVITY_M_PER_S2 = 9.80665
#: International mile [m].
MILE_M = 1609.344
#: US liquid gallon [m^3].
GALLON_US_M3 = 3.785411784e-3
#: Litre [m^3].
LITRE_M3 = 1.0e-3
#: One mile per hour [m/s].
MPH_M_PER_S = 0.44704
#: One kilometre per hour [m/s].
KMH_M_PER_S = 1.0 / 3.6
#: One revolution per minute [rad/s].
RPM_RAD_PER_S = math.pi / 30.0
#: One kilowatt-hour [J].
KWH_J = 3.6e6
#: One pound-force [N].
LBF_N = 4.4482216152605
#: One pound (mass) [kg].
LB_KG = 0.45359237


def mpg_from_m_per_m3(distance_per_volume_m_per_m3: float) -> float:
    """Fuel economy in miles per US gallon from distance per fuel volume [m/m^3]."""
    return distance_per_volume_m_per_m3 * GALLON_US_M3 / MILE_M


def l_per_100km_from_m3_per_m(volume_per_distance_m3_per_m: float) -> float:
    """Fuel consumption in L/100 km from fuel volume per distance [m^3/m]."""
    return volume_per_distance_m3_per_m / LITRE_M3 * 100e3


#: Engineering display unit of an SI unit: SI unit -> (display unit, factor SI -> display).
#: Data stay SI; reports and tables convert at display time only.
DISPLAY_UNITS: dict[str, tuple[str, float]] = {
    "m/s": ("mph", 1.0 / MPH_M_PER_S),
    "rad/s": ("rpm", 1.0 / RPM_RAD_PER_S),
    "kg/s": ("g/s", 1.0e3),
    "W": ("kW", 1.0e-3),
    "J": ("kJ", 1.0e-3),
}


def display_unit(si_unit: str) -> tuple[str, float]:
    """Engineering display unit of ``si_unit`` and the factor SI -> display (unchanged, 1.0,
    for units without one)."""
    return DISPLAY_UNITS.get(si_unit, (si_unit, 1.0))
