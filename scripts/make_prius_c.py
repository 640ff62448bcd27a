"""Build vehval's Toyota Prius c (2012-2019, 1NZ-FXE + P510 transaxle) vehicle file from its sheet.

Usage::

    python scripts/make_prius_c.py SOURCE_DIR [-o src/vehval/data/vehicles/prius_c.yaml]

``SOURCE_DIR`` is the data root holding ``reference/prius_c/specs.md`` (the sourced
specification sheet every quoted value below comes from), ``real/epa_test_car_list/``
(16tstcar.csv: test weight, road-load target, axle ratio, displacement of the PRIUS c rows) and
``real/obd_2014_toyota_prius_c/`` (the on-road OBD log: the pack's power limits as its
battery ECU reports them). Values read from files are read here, not copied by hand.

Published values are used where the sheet has them; the gaps are filled from the packaged
cars, each stated as such:

* engine: the 1NZ-FXE is the 2004 Prius's engine family; the 2004 map (prius_2004.yaml) is
  scaled to the published 54 kW at 4,800 rpm and 111 N·m (speed x 4800 / 5000, torque x 1);
  the 2012 engine's peak efficiency is not published, so the 2004 map's efficiency is kept;
* MG2: the 2016 Prius's MG2 (ORNL-derived, prius_2016.yaml) scaled to the published 45 kW and
  169 N·m; its maximum speed is not published and follows from the two (17,000 rpm x k_p / k_t);
* MG1 (no published rating), the controller and the cold-start model: the 2016 Prius's, whose
  three controller values and cold-start model were calibrated on 2016 PRIUS tests; **no value
  is calibrated on a Prius c test**: every PRIUS c row of the lists is held out;
* battery: the 2016 Prius's NiMH pack scaled (scale_battery) to 120 cells (144 V); capacity
  not published: the NiMH 6.5 Ah of the larger Prius (the sheet's stated assumption); rated
  power: the median discharge limit the car's battery ECU reports in the OBD log;
* transaxle: sun/ring 30/78 and MG2 reduction 2.636 (openinverter, not OEM-confirmed), axle
  ratio 3.19 (EPA list), wheel radius 0.304 m (175/65R15, unloaded, computed).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "src"))

from vehval.epa import apply_selector, read_test_car_list
from vehval.vehicle import load_vehicle
from vehval.vehicle.scaling import machine_scale, scale_battery, scale_engine_map, scale_machine_map

SHEET = "Prius c specification sheet (reference/prius_c/specs.md)"
OBD = "real/obd_2014_toyota_prius_c"

ENGINE_POWER_W = 54e3  # [OEM] toyota.jp: 54 kW (74 PS) / 4,800 rpm
ENGINE_RATED_RPM = 4800.0  # [OEM] toyota.jp
ENGINE_TORQUE_NM = 111.0  # [OEM] toyota.jp: 111 N·m / 3,600-4,400 rpm
MG2_POWER_W = 45e3  # [OEM] toyota.jp: 1LM motor 45 kW
MG2_TORQUE_NM = 169.0  # [OEM] toyota.jp: 169 N·m
MG2_REDUCTION = 2.636  # [COMM] openinverter P510 (copied from P410), not OEM-confirmed
AXLE_RATIO = 3.19  # [REG] EPA lists, every PRIUS c row
WHEEL_RADIUS_M = 0.304  # 175/65R15 unloaded, computed on the sheet
N_CELLS, N_BLOCKS, NOMINAL_V = 120, 10, 144.0  # [SEC] hybridcars.com, driver-web.jp; OBD m1v..m10v
CAPACITY_AH = 6.5  # not published: the sheet's stated assumption (the larger Prius's NiMH)
BOOST_MAX_V = 520.0  # [COMM] openinverter P510 rated voltage
SUN, RING = 30, 78  # [COMM] openinverter P510 "same gearing as the P310 and P410"


def obd_discharge_limit(source: Path) -> tuple[float, int]:
    """Median discharge power limit [W] the battery ECU reports (``Dischg_ctrl``, kW) in the
    OBD log, over rows with a plausible value (the degraded files' 1.5 kW and the +-64
    sentinels excluded: 5 to 60 kW)."""
    vals = []
    for f in sorted((source / OBD).glob("output*.csv")):
        with f.open(encoding="latin-1", newline="") as fh:
            for row in csv.DictReader(line.replace("\0", "") for line in fh):
                try:
                    v = float(row["Dischg_ctrl"])
                except (KeyError, TypeError, ValueError):
                    continue
                if 5.0 <= v < 60.0:
                    vals.append(v * 1e3)
    if not vals:
        raise SystemExit(f"no plausible Dischg_ctrl value in {source / OBD}")
    return float(np.median(vals)), len(vals)


def _yaml(name: str) -> dict:
    return yaml.safe_load((REPO / f"src/vehval/data/vehicles/{name}.yaml").read_text())


def build(source: Path) -> dict:
    b04, b16 = _yaml("prius_2004"), _yaml("prius_2016")
    v16 = load_vehicle("prius_2016")
    tests = apply_selector(read_test_car_list(source / "real/epa_test_car_list/16tstcar.csv"),
                           "model=PRIUS c,year=2016,procedure=hwfet")
    if not tests:
        raise SystemExit("no 2016 PRIUS c HWFET row in 16tstcar.csv")
    t0 = tests[0]
    epa = f"EPA Test Car List 2016 (16tstcar.csv), PRIUS c vehicle {t0.vehicle_id} config {t0.config}"
    veh: dict = {"name": "prius_c",
                 "description": "Toyota Prius c (2012-2019, 1NZ-FXE, P510 transaxle, 144 V NiMH); "
                                "built by scripts/make_prius_c.py from its specification sheet; no "
                                "value calibrated on a Prius c test",
                 "architecture": "power_split"}
    body = dict(b16["body"])
    body.update({"mass_kg": round(t0.mass_kg, 3), "road_load_a_n": round(t0.target_a_n, 4),
                 "road_load_b_n_per_mps": round(t0.target_b_n_per_mps, 5),
                 "road_load_c_n_per_mps2": round(t0.target_c_n_per_mps2, 6)})
    body["sources"] = {**b16["body"]["sources"],
                       "mass_kg": f"{epa}: equivalent test weight",
                       "road_load_a_n": f"{epa}: target coefficient A",
                       "road_load_b_n_per_mps": f"{epa}: target coefficient B",
                       "road_load_c_n_per_mps2": f"{epa}: target coefficient C",
                       "aux_power_w": "prius_2016.yaml: " + b16["body"]["sources"]["aux_power_w"]}
    veh["body"] = body

    e = dict(b04["engine"])
    k_n = ENGINE_RATED_RPM / b04["engine"]["max_speed_rpm"]
    k_t = ENGINE_TORQUE_NM / max(b04["engine"]["max_torque_nm"])
    spd, trq, fuel, tmax = scale_engine_map(e["speed_rpm"], e["torque_nm"], e["fuel_rate_g_per_s"],
                                            e["max_torque_nm"], k_n, k_t)
    how = (f"prius_2004.yaml (1NZ-FXE, the same engine family) scaled by vehval.vehicle.scaling."
           f"scale_engine_map: speed x {k_n:.4f} ({SHEET}: 54 kW at 4,800 rpm, toyota.jp), torque x "
           f"{k_t:.4f} (111 N·m, toyota.jp), efficiency kept (the 2012 engine's peak efficiency "
           f"is not published)")
    e.update({"speed_rpm": [round(x, 1) for x in spd], "torque_nm": [round(x, 3) for x in trq],
              "fuel_rate_g_per_s": [[round(x, 5) for x in r] for r in fuel],
              "max_torque_nm": [round(x, 3) for x in tmax], "max_power_w": ENGINE_POWER_W,
              "max_speed_rpm": round(b04["engine"]["max_speed_rpm"] * k_n, 1),
              "displacement_l": round(t0.displacement_l, 3),
              "cold_start_note": None})
    e.pop("cold_start_note")
    for k in ("warmup_fuel_fraction", "warmup_time_constant_s"):
        if k in b16["engine"]:
            e[k] = b16["engine"][k]
    src = {k: f"prius_2004.yaml: {v}" for k, v in b04["engine"]["sources"].items()}
    src.update({k: how for k in ("speed_rpm", "torque_nm", "fuel_rate_g_per_s", "max_torque_nm")})
    src.update({"max_power_w": f"{SHEET}: 54 kW (toyota.jp, Green Car Congress)",
                "max_speed_rpm": f"{how}: the 2004 limit x {k_n:.4f}",
                "displacement_l": f"{epa}: test vehicle displacement"})
    for k in ("warmup_fuel_fraction", "warmup_time_constant_s"):
        if k in b16["engine"]:
            src[k] = "prius_2016.yaml (calibrated on 2016 PRIUS FTP-75 tests, none of a Prius c): " \
                     + b16["engine"]["sources"][k]
    e["sources"] = {k: v for k, v in src.items() if k in e}
    unc = dict(b16["engine"].get("uncertainty") or {})
    unc.update(b04["engine"].get("uncertainty") or {})
    e["uncertainty"] = {k: v for k, v in unc.items() if k in e}
    veh["engine"] = e

    veh["mg1"] = dict(b16["mg1"])
    veh["mg1"]["sources"] = {k: f"prius_2016.yaml (no published P510 MG1 rating, {SHEET}): {v}"
                             for k, v in b16["mg1"]["sources"].items()}
    m = b16["mg2"]
    k_p, k_tq = MG2_POWER_W / m["max_power_w"], MG2_TORQUE_NM / m["max_torque_nm"]
    n_new = m["max_speed_rpm"] * k_p / k_tq
    k = machine_scale(m["max_speed_rpm"], m["max_power_w"], n_new, MG2_POWER_W)
    spd, trq, loss = scale_machine_map(m["speed_rpm"], m["torque_nm"], m["loss_w"], k)
    how = (f"prius_2016.yaml MG2 scaled by rated power and maximum speed (vehval.vehicle.scaling."
           f"machine_scale): speed x {k.speed:.4f}, torque x {k.torque:.4f}, loss x {k.loss:.4f}")
    veh["mg2"] = {"speed_rpm": [round(x, 1) for x in spd], "torque_nm": [round(x, 3) for x in trq],
                  "loss_w": [[round(float(x), 1) for x in r] for r in loss],
                  "max_torque_nm": MG2_TORQUE_NM, "max_power_w": MG2_POWER_W,
                  "max_speed_rpm": round(n_new, 0),
                  "inertia_kg_m2": round(m["inertia_kg_m2"] * k.torque, 5),
                  "sources": {"speed_rpm": how, "torque_nm": how, "loss_w": how,
                              "max_torque_nm": f"{SHEET}: 169 N·m (toyota.jp)",
                              "max_power_w": f"{SHEET}: 45 kW (toyota.jp)",
                              "max_speed_rpm": f"not published ({SHEET}): 17,000 rpm x k_p / k_t "
                                               f"= {n_new:.0f} rpm, the speed at which the scaled "
                                               "envelope has the published 45 kW and 169 N·m",
                              "inertia_kg_m2": f"prius_2016.yaml x torque ratio {k.torque:.4f}"}}
    if "uncertainty" in m:
        veh["mg2"]["uncertainty"] = {kk: v for kk, v in m["uncertainty"].items()
                                     if kk in veh["mg2"]}

    p_lim, n_lim = obd_discharge_limit(source)
    bat = scale_battery(v16.battery, n_cells=N_CELLS, n_modules=N_BLOCKS, capacity_ah=CAPACITY_AH,
                        nominal_voltage_v=NOMINAL_V, power_limit_w=round(p_lim, 0),
                        ref_name="prius_2016's 168-cell NiMH pack")
    d = bat.model_dump()
    d.pop("uncertainty", None)
    d["sources"] = {kk: f"{SHEET}: 144 V NiMH, 120 cells (hybridcars.com, driver-web.jp), capacity "
                        f"not published (6.5 Ah assumed, as the sheet states); rated power: median "
                        f"Dischg_ctrl of the OBD log ({OBD}, {n_lim} rows) -- {v}"
                    for kk, v in bat.sources.items()}
    veh["battery"] = d
    boost = dict(b16["boost"])
    boost["volt_out_max_v"] = BOOST_MAX_V
    boost["sources"] = {**{kk: f"prius_2016.yaml: {v}" for kk, v in b16["boost"]["sources"].items()},
                        "volt_out_max_v": f"{SHEET}: 520 V (openinverter P510)"}
    veh["boost"] = boost
    pl = dict(b16["planetary"])
    pl.update({"sun_teeth": SUN, "ring_teeth": RING})
    pl["sources"] = {**{kk: f"prius_2016.yaml: {v}" for kk, v in b16["planetary"]["sources"].items()},
                     "sun_teeth": f"{SHEET}: 30 (openinverter P510, not OEM-confirmed)",
                     "ring_teeth": f"{SHEET}: 78 (openinverter P510, not OEM-confirmed)"}
    veh["planetary"] = pl
    dl = dict(b16["driveline"])
    k_r = WHEEL_RADIUS_M / b16["driveline"]["wheel_radius_m"]
    dl.update({"final_drive_ratio": AXLE_RATIO, "mg2_reduction_ratio": MG2_REDUCTION,
               "wheel_radius_m": WHEEL_RADIUS_M,
               "wheel_inertia_kg_m2": round(b16["driveline"]["wheel_inertia_kg_m2"] * k_r ** 4, 4)})
    dl["sources"] = {**{kk: f"prius_2016.yaml: {v}" for kk, v in b16["driveline"]["sources"].items()},
                     "final_drive_ratio": f"{epa}: axle ratio 3.19 (ring gear to axle, {SHEET})",
                     "mg2_reduction_ratio": f"{SHEET}: 2.636 (openinverter P510, not OEM-confirmed)",
                     "wheel_radius_m": f"{SHEET}: 175/65R15, 0.304 m unloaded (computed)",
                     "wheel_inertia_kg_m2": f"prius_2016.yaml x (radius ratio {k_r:.4f})^4 "
                                            "(same tyre construction)"}
    veh["driveline"] = dl
    for blk in ("controller", "driver"):
        veh[blk] = dict(b16[blk])
        veh[blk]["sources"] = {kk: f"prius_2016.yaml (THS controller; not calibrated on a Prius c "
                                   f"test): {v}" for kk, v in b16[blk]["sources"].items()}
    return veh


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("source", type=Path, help="data root with reference/ and real/")
    ap.add_argument("-o", "--output", type=Path,
                    default=REPO / "src/vehval/data/vehicles/prius_c.yaml")
    args = ap.parse_args(argv)
    veh = build(args.source)
    head = ("# Toyota Prius c (2012-2019) for the vehval power-split simulator. GENERATED by\n"
            "# scripts/make_prius_c.py from its specification sheet, the EPA Test Car List and\n"
            "# the packaged 2004 / 2016 Prius files for the gaps. Edit the script, not this file.\n")
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from make_prius_2016 import _write  # the one checked, atomic vehicle-file writer

    _write(veh, args.output, head)
    return 0


if __name__ == "__main__":
    sys.exit(main())
