"""Physics of the powertrain components as pure compiled functions (SI units).

Their parameter blocks are part of the vehicle definition (:mod:`vehval.vehicle.components`).
"""
