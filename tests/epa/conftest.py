"""Synthetic EPA Test Car List files (the real lists are not needed by these tests)."""

from __future__ import annotations

from pathlib import Path

import pytest

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


@pytest.fixture
def prius_list(tmp_path) -> Path:
    """A small 2016 list: EPA and manufacturer Prius tests, an SC03, a Camry, a Prius c."""
    rows = [
        row(number="T1", code=3, desc="HWFE", fe=71.2),
        row(number="T2", code=90, desc="US06", fe=48.6, bags=(35.4, 54.4, "", "")),
        row(number="T3", code=21, desc="Federal fuel 2-day exhaust (w/can load)", fe=78.0,
            bags=(50.7, 126.3, 62.7, 114.4)),
        row(number="T4", orig="MFR", cfg="1", code=3, desc="HWFE", fe=66.0,
            target=(24.153, 0.33502, 0.014096)),
        row(number="T5", orig="MFR", code=95, desc="SC03", fe=58.8),
        row(number="T6", orig="MFR", code=11, desc="Cold CO", fuel=("26", "Cold CO Regular (Tier 2)"),
            fe=56.3, bags=(33.8, 70.8, 49.0, "")),
        row(model="CAMRY HYBRID LE", vid="16-CH1H", number="T7", weight=3625, fe=60.1),
        row(model="PRIUS c", vid="12-NP1H", number="T8", weight=2750, fe=72.0),
    ]
    return write_list(tmp_path / "16tstcar.csv", rows)
