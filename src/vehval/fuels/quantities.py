"""Fuel quantities: the one place where a fuel mass becomes a volume, an energy, CO2, and
the distance per volume (mpg) or volume per distance (L/100 km); and the electric energy
figures of a battery-electric test (Wh/mi, kWh/100 km, MPGe at 33.705 kWh per gallon).

Every stage (results, batch metrics, the simulators, validation, EPA validation) calls these
functions; ``tests/test_one_owner.py`` fails when such a conversion is written anywhere else.
Inputs are SI (kg, m, m^3, kg/m^3, J/kg) floats or numpy arrays; the functions broadcast and
return a float for scalar inputs.

Examples
--------
>>> from vehval.fuels import table_fuel
>>> round(fuel_economy_mpg(16093.44, fuel_volume_m3(2.8, 740.0)), 3)
2.645
>>> economy(2.8, 16093.44, table_fuel("gasoline_e0"))["fuel_consumption_l_per_100km"] > 0
True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vehval.constants import KWH_J, MILE_M
from vehval.errors import VehvalError

__all__ = ["GALLON_EQUIVALENT_J", "KWH_PER_GALLON_EQUIVALENT", "ac_energy_j", "kwh_per_100km",
           "kwh_per_100mi", "kwh_per_100mi_from_mpge", "mpge", "mpge_from_kwh_per_100mi",
           "wh_per_mile", "GALLON_US_M3", "LITRE_M3", "VOLUME_DISPLAY", "combine_mpg", "co2_kg", "economy",
           "fuel_consumption_l_per_100km", "fuel_economy_mpg", "fuel_energy_j", "fuel_volume_m3",
           "l_per_100km_from_volume_per_distance", "mpg_from_volume_per_distance", "mpg_with_fuel_scaled",
           "CO2_PER_C"]

#: US liquid gallon [m^3].
GALLON_US_M3 = 3.785411784e-3
#: Litre [m^3].
LITRE_M3 = 1.0e-3
#: Fuel volume as people read it, per unit system: (unit, factor m^3 -> unit).
VOLUME_DISPLAY: dict[str, tuple[str, float]] = {"us": ("gal", 1.0 / GALLON_US_M3),
                                                "metric": ("L", 1.0 / LITRE_M3)}
#: Mass of CO2 per mass of carbon [-]: 44.009 / 12.011 (IUPAC standard atomic weights).
CO2_PER_C = 44.009 / 12.011


def _out(x: Any) -> Any:
    a = np.asarray(x)
    return float(a) if a.ndim == 0 else a


def fuel_volume_m3(mass_kg: Any, density_kg_per_m3: Any) -> Any:
    """Fuel volume [m^3] of a fuel mass [kg] at a density [kg/m^3]."""
    return _out(np.asarray(mass_kg, float) / np.asarray(density_kg_per_m3, float))


def fuel_economy_mpg(distance_m: Any, volume_m3: Any, *, empty: float = float("nan")) -> Any:
    """Fuel economy [mile/US gal] of a distance [m] driven on a fuel volume [m^3].

    ``empty`` is returned where the volume is not positive (nan by default; the simulators
    say ``inf`` for a run that burned no fuel).
    """
    d = np.asarray(distance_m, float)
    v = np.asarray(volume_m3, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return _out(np.where(v > 0, d / MILE_M / (v / GALLON_US_M3), empty))


def fuel_consumption_l_per_100km(volume_m3: Any, distance_m: Any) -> Any:
    """Fuel consumption [L/100 km] of a fuel volume [m^3] over a distance [m] (nan where the
    distance is not positive)."""
    d = np.asarray(distance_m, float)
    v = np.asarray(volume_m3, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return _out(np.where(d > 0, v / LITRE_M3 / (d / 1e5), np.nan))


def mpg_from_volume_per_distance(volume_per_distance_m3_per_m: Any) -> Any:
    """Fuel economy [mile/US gal] from a fuel volume per distance [m^3/m] (nan where not
    positive): the form of a distance-weighted composite."""
    vpd = np.asarray(volume_per_distance_m3_per_m, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return _out(np.where(vpd > 0, GALLON_US_M3 / MILE_M / vpd, np.nan))


def l_per_100km_from_volume_per_distance(volume_per_distance_m3_per_m: Any) -> Any:
    """Fuel consumption [L/100 km] from a fuel volume per distance [m^3/m]."""
    return _out(np.asarray(volume_per_distance_m3_per_m, float) / LITRE_M3 * 1e5)


def combine_mpg(distances_m: Any, mpgs: Any) -> float:
    """Fuel economy [mile/US gal] of several runs together: total distance over total
    volume, each run's volume its distance [m] over its economy [mile/US gal]."""
    d = np.asarray(distances_m, float)
    e = np.asarray(mpgs, float)
    return float(d.sum() / (d / e).sum())


def mpg_with_fuel_scaled(mpg: Any, fuel_ratio: Any) -> Any:
    """Fuel economy [mile/US gal] of the same distance on ``fuel_ratio`` times the fuel
    (a charge-balance correction: ratio = corrected fuel / measured fuel [-])."""
    return _out(np.asarray(mpg, float) / np.asarray(fuel_ratio, float))


def fuel_energy_j(mass_kg: Any, lhv_j_per_kg: Any) -> Any:
    """Fuel energy [J] of a fuel mass [kg] at a lower heating value [J/kg]."""
    return _out(np.asarray(mass_kg, float) * np.asarray(lhv_j_per_kg, float))


def co2_kg(mass_kg: Any, carbon_mass_fraction: Any) -> Any:
    """CO2 [kg] from burning a fuel mass [kg] of a carbon mass fraction [-] completely."""
    return _out(np.asarray(mass_kg, float) * np.asarray(carbon_mass_fraction, float) * CO2_PER_C)


def economy(mass_kg: float, distance_m: float, fuel: Any, *,
            empty: float = float("nan")) -> dict[str, float | None]:
    """Whole-run fuel quantities of a fuel mass [kg] over a distance [m].

    Parameters
    ----------
    mass_kg, distance_m : float
        Fuel burned [kg] and distance driven [m].
    fuel : Fuel, ResolvedFuel or None
        The fuel (:mod:`vehval.fuels.resolve`); a property it lacks gives None.
    empty : float
        Fuel economy where no fuel was burned (nan or inf).

    Returns
    -------
    dict
        ``fuel_volume_m3`` [m^3], ``fuel_economy_mpg`` [mile/US gal],
        ``fuel_consumption_l_per_100km`` [L/100 km], ``fuel_energy_j`` [J], ``co2_kg`` [kg].
    """
    rho = getattr(fuel, "density_kg_per_m3", None)
    lhv = getattr(fuel, "lhv_j_per_kg", None)
    cf = getattr(fuel, "carbon_mass_fraction", None)
    vol = fuel_volume_m3(mass_kg, rho) if rho else None
    return {
        "fuel_volume_m3": vol,
        "fuel_economy_mpg": fuel_economy_mpg(distance_m, vol, empty=empty) if vol is not None
        else None,
        "fuel_consumption_l_per_100km": fuel_consumption_l_per_100km(vol, distance_m)
        if vol is not None else None,
        "fuel_energy_j": fuel_energy_j(mass_kg, lhv) if lhv else None,
        "co2_kg": co2_kg(mass_kg, cf) if cf else None,
    }


# ------------------------------------------------------------------ electricity (SAE J1634)
# A BEV's energy consumption per distance (Wh/mi, kWh/100 mi, kWh/100 km) and miles per
# gallon of gasoline equivalent (MPGe): distance over AC (wall) energy, one gallon
# equivalent being KWH_PER_GALLON_EQUIVALENT kWh (EPA/DOE, 65 FR 36986: 33.705 kWh per
# gallon). DC (battery terminal) energy becomes AC energy through the charger efficiency
# (wall -> battery): E_AC = E_DC / eta_charger.

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
