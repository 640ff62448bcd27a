"""Physical constants and unit conversions used across the package: one home for each figure.

Data inside vehval is SI (m, s, kg, J, W, rad/s); these factors convert at the edges
(display, regulatory results). Fuel properties are data, not constants (the fuel table, :mod:`vehval.fuels`), and fuel
volumes and fuel economy are computed in :mod:`vehval.fuels.quantities` only.
"""

from __future__ import annotations

import math

#: Standard gravity [m/s^2] (CGPM 1901).
GRAVITY_M_PER_S2 = 9.80665
#: International mile [m].
MILE_M = 1609.344
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
