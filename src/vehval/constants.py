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
#: Plausible best (peak) brake efficiency of a road vehicle's engine [-]: production
#: spark-ignition engines 30-41 %, the best diesels about 42 %; outside the range a fuel map
#: describes no real engine, and no test's engine work over its fuel energy can exceed it.
BRAKE_EFFICIENCY_RANGE = (0.20, 0.45)


#: Environment variable holding the display unit system chosen with ``--units``
#: (read by :mod:`vehval.display`; the CLI sets it for one run).
UNITS_ENV_VAR = "VEHVAL_UNITS"
#: Fewest Monte Carlo draws of any draw vehval makes (0 switches the draws off): fewer give a
#: standard deviation uncertain by more than 7 % of itself (1/sqrt(2(n-1))).
MIN_MC_DRAWS = 100
