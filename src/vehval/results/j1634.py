"""SAE J1634 results of a battery-electric test: DC and AC energy, consumption, MPGe.

The battery's DC energy per phase and for the whole test is the results stage's own
integral of terminal voltage x current (``ess_energy_net_j`` of
:func:`vehval.results.compute_results`, positive discharging, with its uncertainty): this
module adds no second integral. From it and the phase distance:

- AC (wall) energy: a measured recharge energy when the caller gives one (whole test, the
  J1634 wall meter), else DC energy / charger efficiency (wall -> battery);
- consumption: DC and AC Wh/mi, AC kWh/100 mi and kWh/100 km;
- MPGe: distance over AC energy at 33.705 kWh per gallon equivalent
  (:mod:`vehval.fuels.quantities`, the one owner of these conversions).

The figures are the charge-depleting cycle energies a J1634 single-cycle or multi-cycle
test sums per phase; a plug-in hybrid's charge-depleting phases take the same figures
(docs/architectures.md).
"""

from __future__ import annotations

import math
from typing import Any

from vehval.fuels.quantities import (
    ac_energy_j,
    kwh_per_100km,
    kwh_per_100mi,
    mpge,
    wh_per_mile,
)

#: Charger efficiency [-] assumed when neither the vehicle file nor the caller states one
#: (engineering estimate of a level-2 on-board charger, wall to battery; FASTSim 0.86).
DEFAULT_CHARGER_EFFICIENCY = 0.88


def j1634_scope(dc_energy_j: float, distance_m: float, charger_efficiency: float,
                measured_ac_j: float | None = None, u_dc_j: float | None = None) -> dict:
    """J1634 figures of one phase or the whole test.

    Parameters
    ----------
    dc_energy_j : float
        Net battery terminal energy [J], positive discharging.
    distance_m : float
        Distance driven [m].
    charger_efficiency : float
        Wall -> battery [-], used when ``measured_ac_j`` is None.
    measured_ac_j : float, optional
        AC recharge energy measured at the wall [J].
    u_dc_j : float, optional
        Expanded uncertainty (k = 2) of the DC energy [J]; gives ``U_rel_dc_energy``.
    """
    ac = measured_ac_j if measured_ac_j is not None else ac_energy_j(dc_energy_j,
                                                                     charger_efficiency)
    out: dict[str, Any] = {
        "distance_m": distance_m, "dc_energy_kwh": dc_energy_j / 3.6e6,
        "ac_energy_kwh": ac / 3.6e6,
        "ac_basis": "measured wall energy" if measured_ac_j is not None
        else f"DC / charger efficiency {charger_efficiency:g}",
        "dc_wh_per_mile": wh_per_mile(dc_energy_j, distance_m),
        "ac_wh_per_mile": wh_per_mile(ac, distance_m),
        "ac_kwh_per_100mi": kwh_per_100mi(ac, distance_m),
        "ac_kwh_per_100km": kwh_per_100km(ac, distance_m),
        "dc_kwh_per_100km": kwh_per_100km(dc_energy_j, distance_m),
        "mpge": mpge(ac, distance_m),
    }
    if u_dc_j is not None and math.isfinite(u_dc_j) and dc_energy_j > 0:
        rel = u_dc_j / dc_energy_j
        out["U_rel_dc_energy"] = rel  # also that of every AC figure from it
    return out


def j1634_results(res: Any, charger_efficiency: float | None = None,
                  measured_ac_j: float | None = None) -> dict:
    """J1634 figures of every phase and the whole test of a :class:`TestResults`.

    Phases or tests without a battery energy are left out. ``charger_efficiency`` None:
    :data:`DEFAULT_CHARGER_EFFICIENCY`, stated as assumed. ``measured_ac_j`` applies to the
    whole test only (the recharge after it).
    """
    eta = DEFAULT_CHARGER_EFFICIENCY if charger_efficiency is None else float(charger_efficiency)
    scopes: dict[str, Any] = {}
    for scope, vals in res.values.items():
        dc = vals.get("ess_energy_net_j")
        dist = vals.get("distance_m")
        if dc is None or dist is None or not (math.isfinite(dc) and math.isfinite(dist)):
            continue
        u = (res.uncertainty.get(scope, {}).get("ess_energy_net_j") or {}).get("U")
        ac = measured_ac_j if scope == "test" else None
        scopes[scope] = j1634_scope(float(dc), float(dist), eta, ac, u)
    return {"standard": "SAE J1634", "charger_efficiency": eta,
            "charger_efficiency_assumed": charger_efficiency is None,
            "kwh_per_gallon_equivalent": 33.705, "scopes": scopes}
