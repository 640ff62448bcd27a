"""Fuels: the fuel table (:mod:`.table`), the one resolver (:mod:`.resolve`) and the fuel
quantities (:mod:`.quantities`: volume, mpg, L/100 km, energy, CO2).

Foundation layer: every stage that needs a fuel property or a fuel-economy figure imports it
from here (docs/fuels.md).
"""

from vehval.fuels.quantities import (
    CO2_PER_C,
    co2_kg,
    combine_mpg,
    economy,
    fuel_consumption_l_per_100km,
    fuel_economy_mpg,
    fuel_energy_j,
    fuel_volume_m3,
    l_per_100km_from_volume_per_distance,
    mpg_from_volume_per_distance,
    mpg_with_fuel_scaled,
)
from vehval.fuels.resolve import CONSTANT_KEYS, ResolvedFuel, require, resolve_fuel, vehicle_fuel
from vehval.fuels.table import PROPERTIES, Fuel, fuel_properties, known_fuels, table_fuel

__all__ = [
    "CO2_PER_C", "CONSTANT_KEYS", "PROPERTIES", "Fuel", "ResolvedFuel", "co2_kg", "combine_mpg", "economy",
    "fuel_consumption_l_per_100km", "fuel_economy_mpg", "fuel_energy_j", "fuel_properties",
    "fuel_volume_m3", "known_fuels", "l_per_100km_from_volume_per_distance",
    "mpg_from_volume_per_distance", "mpg_with_fuel_scaled", "require", "resolve_fuel", "table_fuel", "vehicle_fuel",
]
