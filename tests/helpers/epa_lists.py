"""Synthetic EPA Test Car List rows and files, and simulated dyno runs of a car built from them.

``row`` is one list row (keyword per column), ``write_list`` writes rows as the published CSV
(latin-1, CR LF); ``camry_rows`` are a sedan's FTP and HWFET rows with the gear columns of
``HEADER``; ``virtual_run`` and ``write_sim_d3`` simulate a vehicle on a cycle as a dyno run
(fuel [kg]) or as a D3-like 1 Hz file (fuel [cc/s], speed [mph]).
"""

from __future__ import annotations

from pathlib import Path

from vehval.constants import MPH_M_PER_S
from vehval.cycles import load_cycle
from vehval.epa.specs_fit import DynoRun
from vehval.sim.simulate import simulate

FULL_HEADER = [
    "Model Year", "Vehicle Manufacturer Name", "Represented Test Veh Make",
    "Represented Test Veh Model", "Test Vehicle ID", "Test Veh Configuration #",
    "Test Veh Displacement (L)", "Rated Horsepower", "Equivalent Test Weight (lbs.)",
    "Axle Ratio", "N/V Ratio", "Test Number", "Test Originator", "Test Procedure Cd",
    "Test Procedure Description", "Test Fuel Type Cd", "Test Fuel Type Description",
    "CO2 (g/mi)", "RND_ADJ_FE", "FE_UNIT", "FE Bag 1", "FE Bag 2", "FE Bag 3", "FE Bag 4",
    "Target Coef A (lbf)", "Target Coef B (lbf/mph)", "Target Coef C (lbf/mph**2)",
    "Set Coef A (lbf)", "Set Coef B (lbf/mph)", "Set Coef C (lbf/mph**2)",
]


GAS = ("61", "Tier 2 Cert Gasoline")


def row(model="PRIUS", make="TOYOTA", vid="16-ZV1H", cfg="2", number="T1", orig="EPA",  # noqa: PLR0913 - one keyword per column of an EPA list row
        code=3, desc="HWFE", fuel=GAS, fe=71.2, bags=("", "", "", ""), weight=3375,
        target=(18.272, 0.29545, 0.013793), year=2016) -> dict:
    vals = [str(year), "Toyota", make, model, vid, cfg, "1.798", "96", str(weight), "2.83",
            "20.0", number, orig, str(code), desc, fuel[0], fuel[1], "125.4", str(fe), "MPG",
            *map(str, bags), *map(str, target), "5.829", "0.1", "0.01"]
    return dict(zip(FULL_HEADER, vals))


def write_list(path: Path, rows: list[dict], header=None, newline="\r\n",
               encoding="latin-1") -> Path:
    """Write rows as an EPA list CSV (latin-1, CR LF by default) with ``header`` columns."""
    header = list(header or FULL_HEADER)
    lines = [",".join(header)]
    for r in rows:
        lines.append(",".join(f'"{r.get(h, "")}"' if "," in str(r.get(h, ""))
                              else str(r.get(h, "")) for h in header))
    path.write_bytes((newline.join(lines) + newline).encode(encoding))
    return path


HEADER = [*FULL_HEADER, "# of Gears", "Tested Transmission Type Code"]


def camry_rows(**kw) -> list[dict]:
    """A sedan's FTP and HWFET rows (one configuration; figures of a 2.5 L 8-speed)."""
    base = dict(model="SEDAN XLE", make="MAKER", vid="18-AV3A", cfg="1", orig="MFR",
                weight=3625, target=(26.508, 0.1976, 0.00733), year=2019)
    base.update(kw)
    rows = [row(number="F1", code=21, desc="Federal fuel 2-day exhaust", fe=37.0,
                bags=(36.1, 35.5, 40.9, ""), **base),
            row(number="H1", code=3, desc="HWFE", fe=58.2, **base)]
    for r in rows:  # displacement, power, axle, N/V of the configuration
        r.update({"Test Veh Displacement (L)": "2.487", "Rated Horsepower": "203",
                  "Axle Ratio": "2.80", "N/V Ratio": "24.7", "# of Gears": "8",
                  "Tested Transmission Type Code": "A"})
    return rows


def virtual_run(veh, cycle: str, tid: str, dt: float = 1.0) -> DynoRun:
    cyc = load_cycle(cycle)
    fuel = simulate(veh, cyc, dt=dt).summary["fuel_mass_kg"]
    return DynoRun(test_id=tid, runs=[cyc], fuel_kg=fuel, distance_m=cyc.distance_m, cold=False)


def write_sim_d3(path, veh, cycle: str) -> None:
    """A speed-and-fuel file like the D3 1 Hz subsets (time, fuel [cc/s], speed [mph])."""
    res = simulate(veh, cycle, dt=1.0)
    t = res.test["veh_spd_simu"].time
    v = res.test["veh_spd_simu"].values / MPH_M_PER_S
    q = res.test["fuel_rate_simu"].values / veh.engine.fuel_density_kg_per_m3 * 1e6
    lines = ["Time[s],Eng_FuelFlow_Direct_DI[ccps],Dyno_Spd[mph]"]
    lines += [f"{a:.1f},{b:.5f},{c:.4f}" for a, b, c in zip(t, q, v)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
