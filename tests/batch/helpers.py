"""Inputs of the batch tests: small D3-style test files and their template.

Imported by the tests of this folder (and its conftest); fixtures stay in conftest.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

TEMPLATE = """template_version: 1
description: batch test fixture
constants:
  fuel_density_kg_per_m3: 745
  fuel_lhv_j_per_kg: 42.6e6
files:
  - match: "*.txt"
    source: dyno
    format: d3
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Engine_Speed: {name: eng_spd_out_test, unit: rpm}
      Bty_Curr: {name: ess_curr_test, unit: A}
      Bty_Volt: {name: ess_volt_test, unit: V}
      SOC: {name: ess_soc_test, unit: "%"}
      Fuel_Flow: {name: fuel_rate_test, unit: g/s}
"""


def write_d3(path: Path, seed: int, n: int = 120, dt: float = 1.0) -> dict:
    """Write a D3-style test and return its exact key metrics (trapezoidal, SI).

    Speed is a smooth hump [mph], fuel flow proportional to speed [g/s], the battery
    discharges at a constant current [A] so SOC falls linearly [%].
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    v_mph = 30.0 * np.sin(np.pi * t / t[-1]) ** 2 * (1 + 0.1 * rng.random())
    fuel_gps = 0.05 * v_mph + 0.1
    curr = np.full(n, 5.0 + rng.random())
    volt = np.full(n, 200.0)
    soc = 60.0 - 0.01 * t
    eng = 1000 + 20 * v_mph
    lines = ["Time[s]\tDyno_Speed[mph]\tEngine_Speed[rpm]\tBty_Curr[A]\tBty_Volt[V]\tSOC[%]\tFuel_Flow[g/s]"]
    for row in zip(t, v_mph, eng, curr, volt, soc, fuel_gps):
        lines.append("\t".join(f"{x:.10g}" for x in row))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\r\n".join(lines) + "\r\n", encoding="utf-8")
    # values as written (rounded to 10 significant digits) for the expected integrals
    back = np.loadtxt(path, skiprows=1, delimiter="\t")
    tt, vv, ff = back[:, 0], back[:, 1] * 0.44704, back[:, 6] * 1e-3
    trap = lambda y: float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(tt)))  # noqa: E731
    dist, fuel = trap(vv), trap(ff)
    return {"distance_m": dist, "fuel_mass_kg": fuel,
            "soc_change": (back[-1, 5] - back[0, 5]) / 100.0,
            "ess_energy_j": trap(back[:, 3] * back[:, 4]),
            "fuel_economy_mpg": dist / 1609.344 / (fuel / 745.0 / 3.785411784e-3)}
