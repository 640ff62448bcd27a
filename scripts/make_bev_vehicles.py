"""Write the shipped battery-electric vehicles, one per sourced spec sheet.

    python scripts/make_bev_vehicles.py            # writes src/vehval/data/vehicles/bev/*.yaml
    python scripts/make_bev_vehicles.py --check    # exit 1 when a shipped file is stale

Every value comes from the car's reference sheet (the project's shared reference folder
``reference/bev/<car>.md``, which cites each figure: maker texts, trade press, the EPA Test
Car List) or is a generic value of :mod:`vehval.vehicle.bev_generic` with its own source.
The test conditions (equivalent test weight, target road load, N/V ratio) are those of the
sheet's suggested validation row of the Test Car List; ``vehval epa validate`` replaces
them with each judged row's own. The wheel radius is the one the row's N/V ratio implies
(r = ratio x 0.44704 x 60 / (2 pi N/V), N/V = motor rpm per mph). Nothing here is fitted
to the lists' consumption figures.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from vehval.constants import LB_KG, LBF_N, MPH_M_PER_S  # noqa: E402
from vehval.vehicle.bev_generic import bev_vehicle_data  # noqa: E402

OUT = ROOT / "src" / "vehval" / "data" / "vehicles" / "bev"

#: car -> (description, list row (list, id, ETW lb, N/V, target A lbf, B lbf/mph, C lbf/mph^2),
#: sheet values {key: (value, source)})
CARS: dict[str, tuple[str, tuple, dict]] = {
    "nissan_leaf_2016": (
        "2016 Nissan Leaf S, 24 kWh (first generation AZE0)",
        ("16tstcar.csv", "KMC272", 3625, 114.7, 29.97, 0.0713, 0.02206),
        {"max_power_w": (80_000.0, "[SEC] CarAdvice '80kW/254Nm'; [REG] 16tstcar Rated HP 107"),
         "max_torque_nm": (254.0, "[SEC] CarAdvice; Car and Driver 2016 test: 187 lb-ft"),
         "final_drive_ratio": (8.19, "[REG] 16tstcar Axle Ratio 8.19 (all Leaf rows)"),
         "battery_kwh": (24.0, "[OEM, via press] Calvert Recorder 2016-07-08: S keeps the "
                         "24 kWh pack"),
         "cells_series": (96, "[SEC] pushevs 2018 article: all Leaf packs 96s2p")}),
    "nissan_leaf_2019": (
        "2019 Nissan Leaf, 40 kWh / 110 kW (second generation ZE1)",
        ("19tstcar.csv", "KWB115 cfg 2", 3750, 114.7, 26.06, 0.3000, 0.01965),
        {"max_power_w": (110_000.0, "[SEC] TFLcar; IndianAutosBlog (Nissan data) 150 PS; "
                         "[REG] 19tstcar Rated HP 147"),
         "max_torque_nm": (320.0, "[SEC] IndianAutosBlog 320 N·m from 0 to 3,283 rpm"),
         "final_drive_ratio": (8.19, "[REG] 19tstcar Axle Ratio 8.19 (all 8 rows)"),
         "battery_kwh": (40.0, "[SEC] Automobile Magazine; Car and Driver: 40 kWh"),
         "cells_series": (96, "[SEC] pushevs; TFLcar: 192 cells, 96s2p"),
         "max_speed_rpm": (10_200.0, "computed in the sheet: top speed 90 mph (TFLcar) with "
                           "ratio 8.19 and r 0.305-0.311 m gives 10,100-10,300 rpm")}),
    "bmw_i3_2016": (
        "2016 BMW i3 BEV, 60 Ah (22 kWh) pack",
        ("16tstcar.csv", "VX51000", 3125, 121.6, 22.9, 0.346, 0.01626),
        {"max_power_w": (125_000.0, "[OEM, via press] BMWBLOG; BMW Macau technical data; "
                         "[REG] 16tstcar Rated HP 168"),
         "max_torque_nm": (250.0, "[OEM, via press] BMWBLOG; BMW Macau technical data"),
         "final_drive_ratio": (9.70, "[REG] 16tstcar Axle Ratio 9.70"),
         "battery_kwh": (21.6, "[COMM] bmwi3.blogspot.com: 96 x 60 Ah x 3.75 V = 21.6 kWh "
                         "(BMW rated 22 kWh)"),
         "cells_series": (96, "[SEC] batterydesign.net; pushevs: 96 cells, all in series"),
         "max_speed_rpm": (11_400.0, "[SEC] evo.co.uk; Wired: 11,400 rpm")}),
    "chevrolet_bolt_2019": (
        "2019 Chevrolet Bolt EV, 60 kWh",
        ("19tstcar.csv", "001HFV5002", 3875, 96.0, 28.4, 0.2018, 0.01948),
        {"max_power_w": (150_000.0, "[OEM, via press] ChargedEVs; [REG] 19tstcar Rated HP 200"),
         "max_torque_nm": (360.0, "[OEM, via press] ChargedEVs: 266 lb-ft"),
         "final_drive_ratio": (7.05, "[REG] 19tstcar Axle Ratio 7.05"),
         "battery_kwh": (60.0, "[OEM, via press] ChargedEVs quoting GM; Electrek: 60 kWh"),
         "cells_series": (96, "[OEM, via press] engineering.com: 288 cells, 96s3p"),
         "max_speed_rpm": (8_736.0, "computed in the sheet: top speed 91 mph "
                           "(engineering.com) x list N/V 96.0")}),
    "chevrolet_spark_ev_2016": (
        "2016 Chevrolet Spark EV (LG pack, 3.87 final drive)",
        ("16tstcar.csv", "00MBEV4012", 3125, 58.2, 21.96, 0.1688, 0.01806),
        {"max_power_w": (103_650.0, "[REG] 16tstcar Rated HP 139 (= 103.7 kW); GM texts "
                         "conflict (100 kW vs 105 kW)"),
         "max_torque_nm": (444.0, "[OEM, via press] conceptcarz (GM MY2015 text): 327 lb-ft"),
         "final_drive_ratio": (3.87, "[REG] 16tstcar Axle Ratio 3.87; InsideEVs quoting GM"),
         "battery_kwh": (19.0, "[OEM, via press] InsideEVs quoting GM: 19 kWh, 192 cells "
                         "(GM MY2015 text says 18.4)"),
         "cells_series": (96, "engineering estimate: 192 LG cells (InsideEVs) as 96s2p; "
                          "the arrangement is not published"),
         "max_speed_rpm": (5_238.0, "computed in the sheet: top speed 90 mph (Engadget) x "
                           "list N/V 58.2")}),
    "fiat_500e_2016": (
        "2016 Fiat 500e, 24 kWh",
        ("16tstcar.csv", "L6FFE4230", 3250, 145.0, 24.91, 0.2365, 0.01816),
        {"max_power_w": (83_000.0, "[OEM, via press] Allpar; [REG] 16tstcar Rated HP 110"),
         "max_torque_nm": (200.0, "[OEM, via press] Allpar (Fiat launch data)"),
         "final_drive_ratio": (9.59, "[REG] 16tstcar Axle Ratio 9.59"),
         "battery_kwh": (24.0, "[OEM, via press] Allpar; [SEC] PluginCars"),
         "cells_series": (97, "engineering estimate: cell arrangement not published; 97 "
                          "cells in series (the 364 V class of 24 kWh packs)")}),
}


def wheel_radius_m(ratio: float, n_v: float) -> float:
    """Wheel radius [m] implied by the list's N/V ratio (motor rpm per mph)."""
    return ratio * MPH_M_PER_S * 60.0 / (2.0 * math.pi * n_v)


def vehicle(name: str, generic: dict | None = None) -> dict:
    """The vehicle-file mapping of one car (``generic``: key -> (value, source) replacing
    generic values, for a cross-validation)."""
    desc, (lst, vid, etw, nv, a, b, c), sheet = CARS[name]
    row = f"EPA Test Car List {lst} row {vid} (reference sheet {name}.md)"
    vals = {k: v for k, (v, _) in sheet.items()}
    src = {k: s + f" (reference sheet {name}.md)" for k, (_, s) in sheet.items()}
    vals.update({"mass_kg": etw * LB_KG, "road_load_a_n": a * LBF_N,
                 "road_load_b_n_per_mps": b * LBF_N / MPH_M_PER_S,
                 "road_load_c_n_per_mps2": c * LBF_N / MPH_M_PER_S ** 2,
                 "wheel_radius_m": round(wheel_radius_m(vals["final_drive_ratio"], nv), 4)})
    src.update({"mass_kg": f"{row}: equivalent test weight {etw} lb",
                "road_load_a_n": f"{row}: target A {a} lbf",
                "road_load_b_n_per_mps": f"{row}: target B {b} lbf/mph",
                "road_load_c_n_per_mps2": f"{row}: target C {c} lbf/mph^2",
                "wheel_radius_m": f"computed from {row}: N/V {nv} and the axle ratio"})
    for k, (v, s) in (generic or {}).items():
        vals[k], src[k] = v, s
    data = bev_vehicle_data(name=name, description=desc + "; test conditions of " + row,
                            values=vals, sources=src)
    return data


def render(name: str) -> str:
    head = ("# Generated by scripts/make_bev_vehicles.py from the sourced reference sheet: do "
            "not edit by hand.\n")
    return head + yaml.safe_dump(vehicle(name), sort_keys=False, allow_unicode=True, width=100)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="exit 1 when a shipped file is stale")
    args = ap.parse_args(argv)
    stale = []
    OUT.mkdir(parents=True, exist_ok=True)
    for name in CARS:
        path = OUT / f"{name}.yaml"
        text = render(name)
        if args.check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                stale.append(path.name)
            continue
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path.relative_to(ROOT)}")
    if stale:
        print(f"stale: {', '.join(stale)}: run python scripts/make_bev_vehicles.py")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
