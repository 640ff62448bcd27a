"""The energy flow of a battery-electric test, in SAE J1634 terms.

Per phase and for the whole test: distance, DC battery energy (terminal V x I, the results
stage's), AC (wall) energy, consumption in kWh/100 mi and kWh/100 km, MPGe (the results'
:mod:`vehval.results.j1634` block), and the regenerative share: the DC energy the battery
took back while braking over the energy it delivered (from the measured voltage and
current over the phase's segments). No fuel section: the car burns none.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.constants import KWH_J
from vehval.display import as_unit
from vehval.integrals import battery_power, integral
from vehval.report import sections as S
from vehval.report.plots import pick
from vehval.test import Test


def _energies(test: Test, segments: list) -> tuple[float, float] | None:
    """DC energy out of and back into the battery [J] over ``segments`` (record time)."""
    v, i = pick(test, "ess_volt"), pick(test, "ess_curr")
    if v is None or i is None:
        return None
    t = i.time
    p = battery_power(np.interp(t, v.time, v.values), i.values)
    ok = np.isfinite(p)
    out = back = 0.0
    for a, b in segments:
        m = ok & (t >= a) & (t <= b)
        if m.sum() < 2:
            continue
        out += integral(t[m], np.maximum(p[m], 0.0))
        back += integral(t[m], np.maximum(-p[m], 0.0))
    return out, back


def bev_energy_section(test: Test, results: dict[str, Any] | None) -> S.Section:
    """The report's energy section of a battery-electric test (see the module docstring)."""
    sec = S.Section("engineering", "Energy flow (SAE J1634)",
                    intro="Battery (DC) and wall (AC) energy, consumption and MPGe per phase "
                          "and for the test; the regenerative share is the DC energy "
                          "recovered while braking over the DC energy delivered.")
    j = (results or {}).get("j1634") or {}
    scopes = j.get("scopes") or {}
    if not scopes:
        sec.notes.append("No SAE J1634 figures: the results stage found no battery energy "
                         "(battery voltage and current) in this test.")
        return sec
    segs = {p["name"]: [tuple(s) for s in p.get("segments_s", [])]
            for p in (results or {}).get("phases", [])}
    t0, t1 = test.span()
    rows = []
    for scope, f in scopes.items():
        e = _energies(test, segs.get(scope, [(t0, t1)]))
        share = as_unit(e[1] / e[0], "%") if e and e[0] > 0 else None
        rows.append([scope, as_unit(f["distance_m"], "km"), as_unit(f["dc_energy_kwh"] * KWH_J, "Wh"),
                     as_unit(f["ac_energy_kwh"] * KWH_J, "Wh"), f["ac_kwh_per_100mi"],
                     f["ac_kwh_per_100km"], f["mpge"], share])
    sec.tables.append(S.Table(
        "SAE J1634 energy per phase", ["scope", "distance [km]", "DC energy [Wh]",
                                       "AC energy [Wh]", "AC [kWh/100 mi]",
                                       "AC [kWh/100 km]", "MPGe", "regenerative share [%]"],
        rows, key="energies"))
    test_f = scopes.get("test")
    if test_f:
        sec.notes.insert(0, f"Whole test (SAE J1634, AC): {test_f['ac_kwh_per_100mi']:.1f} "
                            f"kWh/100 mi, {test_f['ac_kwh_per_100km']:.1f} kWh/100 km, "
                            f"{test_f['mpge']:.0f} MPGe; AC basis: {test_f['ac_basis']}"
                            + (" (assumed)" if j.get("charger_efficiency_assumed") else ""))
    return sec
