"""Attack campaign III, inputs shared by its classes: virtual dyno tests, EPA lists, the real
Cruze files' locations. Each input is made once per campaign folder (classes run in parallel
threads), when the first case needing it runs."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
import threading
from collections import defaultdict
from pathlib import Path
from typing import Callable

from attack3_common import REPO
from attack_campaign2 import EPA_HEADER, _text, epa_row, write_epa

CRUZE_REAL = Path(os.environ.get("VEHVAL_SHARED_DATA", REPO.parent / "shared" / "data")) \
    / "real" / "d3_2014_chevrolet_cruze_diesel"
CRUZE_TEMPLATE = REPO / "tests" / "qa" / "templates" / "cruze.yaml"
VEHICLES = REPO / "src" / "vehval" / "data" / "vehicles"

_LOCKS: defaultdict[str, threading.Lock] = defaultdict(threading.Lock)


def once(path: Path, make: Callable[[Path], None]) -> Path:
    """``make(path)`` the first time ``path`` is asked for (thread-safe); ``path``."""
    with _LOCKS[str(path)]:
        mark = path.parent / f".{path.name}.done"
        if not mark.is_file():
            path.parent.mkdir(parents=True, exist_ok=True)
            make(path)
            mark.write_text("ok")
    return path


def run_vehval(*args) -> None:
    """Run ``vehval ARGS`` to make an input; fails loudly (the case is then 'not run')."""
    r = subprocess.run([sys.executable, "-m", "vehval", *map(str, args)], capture_output=True,
                       text=True, timeout=900)
    if r.returncode != 0:
        raise RuntimeError(f"vehval {' '.join(map(str, args[:3]))}: {r.stderr[-300:]}")


def synth(root: Path, vehicle: str, cycle: str, seed: int = 3) -> Path:
    """A virtual dyno test (``vehval synth``, no injected fault): its folder."""
    return once(root / "_synth" / f"{vehicle}_{cycle}_{seed}", lambda p: run_vehval(
        "synth", "--vehicle", vehicle, "--cycle", cycle, "--seed", seed, "--faults", "none",
        "-o", p))


def d3_of(folder: Path) -> Path:
    return next(folder.glob("*_d3.txt"))


SEDAN_HEADER = [*EPA_HEADER, "# of Gears", "Tested Transmission Type Code"]


def sedan_rows(**over) -> list[dict]:
    """A gasoline sedan's FTP and HWFET rows (2.5 L, 8 speeds) for ``epa vehicle``."""
    base = {"Model Year": "2019", "Vehicle Manufacturer Name": "Maker",
            "Represented Test Veh Make": "MAKER", "Represented Test Veh Model": "SEDAN XLE",
            "Test Vehicle ID": "18-AV3A", "Test Veh Configuration #": "1",
            "Test Originator": "MFR", "Equivalent Test Weight (lbs.)": "3625",
            "Target Coef A (lbf)": "26.508", "Target Coef B (lbf/mph)": "0.1976",
            "Target Coef C (lbf/mph**2)": "0.00733", "Test Veh Displacement (L)": "2.487",
            "Rated Horsepower": "203", "Axle Ratio": "2.80", "N/V Ratio": "24.7",
            "# of Gears": "8", "Tested Transmission Type Code": "A"}
    base.update(over)
    ftp = epa_row(**{**base, "Test Number": "F1", "Test Procedure Cd": "21",
                     "Test Procedure Description": "Federal fuel 2-day exhaust",
                     "RND_ADJ_FE": "37.0", "FE Bag 1": "36.1", "FE Bag 2": "35.5",
                     "FE Bag 3": "40.9"})
    hwy = epa_row(**{**base, "Test Number": "H1", "Test Procedure Cd": "3",
                     "Test Procedure Description": "HWFE", "RND_ADJ_FE": "58.2"})
    return [ftp, hwy]


def write_list(path: Path, rows: list[dict], header: list[str], *, newline: str = "\r\n",
               bom: bool = False) -> Path:
    """An EPA Test Car List with ``header`` columns, ``newline`` line ends, optional BOM."""
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [",".join(header)]
    for r in rows:
        lines.append(",".join(f'"{r.get(h, "")}"' if "," in str(r.get(h, "")) else
                              str(r.get(h, "")) for h in header))
    body = (newline.join(lines) + newline).encode("utf-8")
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + body)
    return path


def sedan_tests(root: Path) -> Path:
    """The sedan's list and three virtual speed-and-fuel tests of it (the fuel in cm³/s as
    the D3 1 Hz subsets write it), with their template: the folder."""
    def make(d: Path) -> None:
        from vehval.constants import MPH_M_PER_S
        from vehval.epa import read_test_car_list
        from vehval.epa.specs import specs_from_tests, vehicle_from_specs
        from vehval.sim.simulate import simulate

        lst = write_list(d / "19tstcar.csv", sedan_rows(), SEDAN_HEADER)
        truth = vehicle_from_specs(specs_from_tests(read_test_car_list(lst)), 0.43, 1.1,
                                   cold_start=False)
        for name, cyc in (("t1", "udds"), ("t2", "us06"), ("t3", "hwfet")):
            res = simulate(truth, cyc, dt=1.0)
            t = res.test["veh_spd_simu"].time
            v = res.test["veh_spd_simu"].values / MPH_M_PER_S
            q = res.test["fuel_rate_simu"].values / truth.engine.fuel_density_kg_per_m3 * 1e6
            lines = ["Time[s],Eng_FuelFlow_Direct_DI[ccps],Dyno_Spd[mph]"]
            lines += [f"{a:.1f},{b:.5f},{c:.4f}" for a, b, c in zip(t, q, v)]
            _text(d / f"{name} Test Data.txt", "\n".join(lines) + "\n")
        for unit, name in (("ccps", "t.yaml"), ("g/s", "t_gps.yaml")):
            _text(d / name, "template_version: 1\nfuel: gasoline_e0\nfiles:\n- source: dyno\n"
                  "  format: d3\n  time: {column: Time}\n  channels:\n"
                  f"    Eng_FuelFlow_Direct_DI: {{name: fuel_rate_test, unit: {unit}}}\n"
                  "    Dyno_Spd: {name: veh_spd_test, unit: mph}\n")
    return once(root / "_sedan", lambda p: (p.mkdir(parents=True, exist_ok=True), make(p)))


def prius_list(root: Path) -> Path:
    """A 2016 Prius list: an EPA HWFET and an EPA FTP row (``epa calibrate``, ``validate``)."""
    return once(root / "_lists" / "prius.csv", lambda p: write_epa(p, [
        epa_row(), epa_row(**{"Test Number": "T2", "Test Procedure Cd": "21",
                              "Test Procedure Description": "Federal fuel 2-day exhaust",
                              "RND_ADJ_FE": "54.0", "FE Bag 1": "52.1", "FE Bag 2": "56.3",
                              "FE Bag 3": "54.9"})]))


def sha(path: Path) -> str | None:
    return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None


def base_write(p: Path) -> None:
    from attack_campaign import write_d3

    write_d3(p)
