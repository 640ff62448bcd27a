"""Write src/vehval/data/vehicles/insight_2000.yaml from the ADVISOR Insight component data.

    python scripts/make_insight.py [--ref DIR] [--check]

The ADVISOR 2003 data files of the 2000 Honda Insight (NREL; ADVISOR licence, MIT-style,
ADVISOR_LICENSE.txt beside the files) are read for their FIGURES only: the numbers of the
named arrays are parsed, never their MATLAB code or text; every value of the YAML records
the file and array it came from and any scaling or unit conversion. ``--ref`` is the folder
of the reference files (default: ``../shared/data/reference/advisor_insight`` beside the
repository, or ``$VEHVAL_SHARED_DATA/reference/advisor_insight``); ``--check`` exits 1 when
the shipped file differs from what the data give.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "src" / "vehval" / "data" / "vehicles" / "insight_2000.yaml"
LBFT = 1.355818  # [N·m per lb·ft]
G = 9.80665      # [m/s^2]
MPH = 0.44704    # [m/s per mph]
ADV = "ADVISOR 2003 Insight data"


def ref_dir(arg: str | None) -> Path:
    """The folder of the ADVISOR Insight reference files."""
    if arg:
        return Path(arg)
    env = os.environ.get("VEHVAL_SHARED_DATA")
    base = Path(env) if env else ROOT.parent / "shared" / "data"
    return base / "reference" / "advisor_insight"


def figures(path: Path, name: str) -> list[list[float]]:
    """The numbers of array ``name`` in a MATLAB data file, as rows (figures only)."""
    text = path.read_text(encoding="latin-1")
    m = re.search(rf"^\s*{re.escape(name)}\s*=\s*(?:[\d.]+\s*\*\s*)?\[", text, re.M)
    if m is None:
        raise SystemExit(f"{path.name}: no array '{name}'")
    body = text[m.end():text.index("]", m.end())]
    rows = []
    for line in re.split(r"[;\n]", body):
        line = line.split("%")[0].replace("...", " ").replace(",", " ")
        nums = [float(x) for x in re.findall(r"-?\d+(?:\.\d*)?(?:e-?\d+)?|-?\.\d+", line)]
        if nums:
            rows.append(nums)
    return rows


def scalar(path: Path, name: str) -> float:
    """The first number assigned to ``name`` in a MATLAB data file."""
    text = path.read_text(encoding="latin-1")
    m = re.search(rf"^\s*{re.escape(name)}\s*=\s*(-?[\d.]+)", text, re.M)
    if m is None:
        raise SystemExit(f"{path.name}: no scalar '{name}'")
    return float(m.group(1))


def flat(rows: list[list[float]]) -> list[float]:
    return [x for r in rows for x in r]


def engine(d: Path) -> dict:
    f = d / "FC_INSIGHT.m"
    spd = flat(figures(f, "fc_map_spd"))
    trq = [round(x * LBFT, 3) for x in flat(figures(f, "fc_map_trq"))]
    tmax = [round(x * LBFT, 3) for x in flat(figures(f, "fc_max_trq"))]
    fuel = figures(f, "fc_fuel_map")
    pmax = max(t * s * math.pi / 30 for t, s in zip(tmax, spd))
    src = f"{ADV}, FC_INSIGHT.m (ANL test data, NREL)"
    return {
        "speed_rpm": spd, "torque_nm": trq, "fuel_rate_g_per_s": fuel, "max_torque_nm": tmax,
        "max_power_w": round(pmax, 1), "max_speed_rpm": max(spd),
        "idle_speed_rpm": round(scalar(d / "PTC_INSIGHT.m", "vc_idle_spd") * 30 / math.pi, 1),
        "fire_speed_rpm": round(scalar(d / "PTC_INSIGHT.m", "vc_idle_spd") * 30 / math.pi, 1),
        "motoring_torque_nm": 7.0, "inertia_kg_m2": scalar(f, "fc_inertia"),
        "fuel": "gasoline_e0", "displacement_l": 1.0,
        "sources": {
            "speed_rpm": f"{src}: fc_map_spd (rpm figures)",
            "torque_nm": f"{src}: fc_map_trq lb·ft x {LBFT}",
            "fuel_rate_g_per_s": f"{src}: fc_fuel_map (g/s); the map saturates in its last "
                                 "two torque columns (extrapolated above the tested points)",
            "max_torque_nm": f"{src}: fc_max_trq lb·ft x {LBFT} (Honda UC Davis presentation)",
            "max_power_w": f"{src}: the largest torque x speed on fc_max_trq",
            "max_speed_rpm": f"{src}: top of fc_map_spd",
            "idle_speed_rpm": f"{ADV}, PTC_INSIGHT.m: vc_idle_spd 94 rad/s (NREL testing)",
            "fire_speed_rpm": f"{ADV}, PTC_INSIGHT.m: vc_idle_spd (the IMA cranks to idle)",
            "motoring_torque_nm": f"{src}: closed-throttle torque at 800 rpm (about -7 N·m, "
                                  "its lowest-speed value)",
            "inertia_kg_m2": f"{src}: fc_inertia (marked unknown there)",
            "displacement_l": f"{src}: 1.0 L VTEC-E",
            "fuel": f"{src}: gasoline (fc_fuel_den 749 g/L, fc_fuel_lhv 42.6 kJ/g); the fuel table's test gasoline",
        },
    }


def motor(d: Path) -> dict:
    f = d / "MC_INSIGHT_draft.m"
    trq = flat(figures(f, "mc_map_trq"))
    spd = flat(figures(f, "mc_map_spd"))
    eff = [[x * 0.01 for x in r] for r in figures(f, "mc_eff_map")]
    tmax = flat(figures(f, "mc_max_trq"))
    trq = [-tmax[0]] + trq  # the generating limit -46.5 N·m: the -36 N·m column repeated
    eff = [[r[0]] + r for r in eff]
    loss = []
    for i, s in enumerate(spd):
        w = max(s, spd[1]) * math.pi / 30  # the 0 rpm row takes the 500 rpm row's losses
        row = []
        for j, t in enumerate(trq):
            tt = t if t != 0 else trq[j + 1]  # the 0 N·m column takes its neighbour's
            e = eff[i][j]
            p = abs(tt) * w
            row.append(round(p * (1 / e - 1) if tt > 0 else p * (1 - e), 2))
        loss.append(row)
    src = f"{ADV}, MC_INSIGHT_draft.m (preliminary; efficiencies of a Honda 49 kW PM motor, " \
          "torque axis scaled to 10 kW; not validated)"
    return {
        "speed_rpm": spd, "torque_nm": trq, "loss_w": loss, "max_torque_nm": tmax[0],
        "max_power_w": 10000.0, "max_speed_rpm": max(spd),
        "inertia_kg_m2": scalar(f, "mc_inertia"),
        "sources": {
            "speed_rpm": f"{src}: mc_map_spd (rpm figures)",
            "torque_nm": f"{src}: mc_map_trq plus a -46.5 N·m column (the generating limit)",
            "loss_w": f"{src}: loss = |T w| (1/eta - 1) motoring, |T w| (1 - eta) generating "
                      "from mc_eff_map; the -46.5 N·m column repeats -36 N·m's efficiency, the "
                      "0 N·m column and 0 rpm row take their neighbours'",
            "max_torque_nm": f"{src}: mc_max_trq up to 2000 rpm",
            "max_power_w": f"{src}: 10 kW continuous rating (overtorque factor 1)",
            "max_speed_rpm": f"{src}: top of mc_map_spd",
            "inertia_kg_m2": f"{src}: mc_inertia",
        },
    }


def battery(d: Path) -> dict:
    f = d / "ESS_NIMH6.m"
    n_mod = 20
    soc = flat(figures(f, "ess_soc"))
    voc = [round(x * n_mod, 3) for x in figures(f, "ess_voc")[1]]
    rd = [round(x * n_mod, 4) for x in figures(f, "ess_r_dis")[1]]
    rc = [round(x * n_mod, 4) for x in figures(f, "ess_r_chg")[1]]
    vmin, vmax = scalar(f, "ess_min_volts") * n_mod, scalar(f, "ess_max_volts") * n_mod
    pdis = [round(vmin * (v - vmin) / r) for v, r in zip(voc, rd)]
    pchg = [round(vmax * (vmax - v) / r) for v, r in zip(voc, rc)]
    src = f"{ADV}, ESS_NIMH6.m (NREL HPPC test of a MY2000 Insight pack, 25 C)"
    lo = scalar(d / "PTC_INSIGHT.m", "cs_lo_soc")
    hi = scalar(d / "PTC_INSIGHT.m", "cs_hi_soc")
    return {
        "soc": soc, "ocv_v": voc, "resistance_discharge_ohm": rd, "resistance_charge_ohm": rc,
        "discharge_power_limit_w": pdis, "charge_power_limit_w": pchg,
        "capacity_ah": figures(f, "ess_max_ah_cap")[0][0], "n_cells": 120, "n_modules": n_mod,
        "nominal_voltage_v": 144.0, "soc_min": lo, "soc_max": hi, "chemistry": "nimh",
        "sources": {
            "soc": f"{src}: ess_soc",
            "ocv_v": f"{src}: ess_voc per module x 20 modules (INSIGHT_defaults_in.m)",
            "resistance_discharge_ohm": f"{src}: ess_r_dis per module x 20",
            "resistance_charge_ohm": f"{src}: ess_r_chg per module x 20",
            "discharge_power_limit_w": f"{src}: V_min (V - V_min) / R_dis at the 6 V/module "
                                       "floor (ess_min_volts x 20)",
            "charge_power_limit_w": f"{src}: V_max (V_max - V) / R_chg at the 9 V/module "
                                    "ceiling (ess_max_volts x 20)",
            "capacity_ah": f"{src}: ess_max_ah_cap (6.0 Ah measured; 6.5 Ah published)",
            "n_cells": f"{src}: 6 cells per module x 20 modules",
            "n_modules": f"{ADV}, INSIGHT_defaults_in.m: ess_module_num = 20",
            "nominal_voltage_v": f"{src}: 120 cells x 1.2 V",
            "soc_min": f"{ADV}, PTC_INSIGHT.m: cs_lo_soc",
            "soc_max": f"{ADV}, PTC_INSIGHT.m: cs_hi_soc",
            "chemistry": f"{src}: spiral-wound NiMH",
        },
    }


def chassis(d: Path) -> tuple[dict, dict]:
    veh, wh = d / "VEH_INSIGHT.m", d / "WH_INSIGHT.m"
    mass = 1000.0
    rr = scalar(wh, "wh_1st_rrc")
    r = scalar(wh, "wh_radius")
    axle = flat(figures(wh, "wh_axle_loss_trq"))
    axle_nm = 0.4 * (axle[0] + (axle[1] - axle[0]) * mass / 2000.0)
    cda = scalar(veh, "veh_CD") * scalar(veh, "veh_FA")
    rho = scalar(veh, "veh_air_density")
    body = {
        "mass_kg": mass, "road_load_a_n": round(mass * G * rr + axle_nm / r, 2),
        "road_load_b_n_per_mps": 0.0, "road_load_c_n_per_mps2": round(0.5 * rho * cda, 4),
        "aux_power_w": 0.0,
        "sources": {
            "mass_kg": f"{ADV}, INSIGHT_defaults_in.m: veh_mass = 1000 kg (the help page's "
                       "test mass; VEH_INSIGHT.m's own 800 kg is overridden there)",
            "road_load_a_n": f"{ADV}: m g Crr (WH_INSIGHT.m wh_1st_rrc 0.0054) + axle loss "
                             "(wh_axle_loss_trq x 0.4 at 1000 kg, 5.6 N·m) / wh_radius",
            "road_load_b_n_per_mps": f"{ADV}, WH_INSIGHT.m: second-order rolling coefficient 0",
            "road_load_c_n_per_mps2": f"{ADV}, VEH_INSIGHT.m: 0.5 veh_air_density veh_CD "
                                      "veh_FA",
            "aux_power_w": f"{ADV}, ACC_INSIGHT.m: mechanical accessory load 0",
        },
    }
    drive = {
        "final_drive_ratio": 3.21, "final_drive_efficiency": 1.0, "wheel_radius_m": r,
        "wheel_inertia_kg_m2": round(181 / 2.205 * r * r / 2 * 4 / 4, 4),
        "brake_max_force_n": round(0.9 * mass * G, 0),
        "sources": {
            "final_drive_ratio": f"{ADV}, TX_5SPD_SI_INSIGHT.m: the 3.21 inside gb_ratio",
            "final_drive_efficiency": "1: the gearbox efficiency holds the driveline losses",
            "wheel_radius_m": f"{ADV}, WH_INSIGHT.m: wh_radius (Car & Driver mph/1000 rpm)",
            "wheel_inertia_kg_m2": f"{ADV}, WH_INSIGHT.m: wh_inertia (181 lb of wheels as "
                                   "cylinders)",
            "brake_max_force_n": "engineering estimate: about 0.9 g at the test mass",
        },
    }
    return body, drive


def gearbox(d: Path, drive: dict) -> dict:
    tx, ptc = d / "TX_5SPD_SI_INSIGHT.m", d / "PTC_INSIGHT.m"
    ratios = flat(figures(tx, "gb_ratio"))
    table = figures(ptc, "tx_spd_dep_upshift")
    up = sorted({round(r[0] / 3.6, 3) for r in table if 0 < r[0] < 500})  # km/h figures
    dn = [round(u - 8 / 3.6, 3) for u in up]
    return {
        "ratios": ratios, "efficiency": 0.92, "upshift_speed_mps": up,
        "upshift_speed_full_load_mps": up, "downshift_speed_mps": dn,
        "downshift_speed_full_load_mps": dn, "shift_time_s": 1.0,
        "sources": {
            "ratios": f"{ADV}, TX_5SPD_SI_INSIGHT.m: gb_ratio without the 3.21 final drive "
                      "(Car & Driver, Jan 2000)",
            "efficiency": f"{ADV}, tx_insight_26_50_5.mat: typical of tx_eff_map at 100 rad/s "
                          "(0.88-0.95; a VW loss equation, not measured)",
            "upshift_speed_mps": f"{ADV}, PTC_INSIGHT.m: tx_spd_dep_upshift 24/40/64/75 km/h "
                                 "(the help page's speed-based shifting)",
            "upshift_speed_full_load_mps": "as upshift_speed_mps (speed-based shifting)",
            "downshift_speed_mps": "engineering choice: the upshift speeds less 8 km/h "
                                   "(hysteresis; the PTC table has none)",
            "downshift_speed_full_load_mps": "as downshift_speed_mps",
            "shift_time_s": "engineering estimate: 1 s with the clutch open (manual)",
        },
    }


def controller(d: Path) -> dict:
    p = d / "PTC_INSIGHT.m"
    tmax = flat(figures(d / "MC_INSIGHT_draft.m", "mc_max_trq"))[0]
    src = f"{ADV}, PTC_INSIGHT.m"
    return {
        "soc_target": 0.69, "assist_threshold_nm": scalar(p, "cs_dl_assist_trq_threshold"),
        "assist_min_nm": round(scalar(p, "cs_mc_assist_min_frac") * tmax, 2),
        "assist_slope": round(1 / 11, 5),
        "assist_max_nm": round(scalar(p, "cs_mc_assist_max_frac") * tmax, 2),
        "assist_min_gear": 2, "assist_soc_min": scalar(p, "cs_lo_soc"),
        "regen_threshold_nm": scalar(p, "cs_dl_regen_trq_threshold"),
        "regen_fraction": scalar(p, "cs_mc_regen_slope"),
        "regen_min_speed_mps": round(scalar(p, "cs_decel_regen_threshold") * MPH, 3),
        "regen_soc_max": scalar(p, "cs_hi_soc"), "charge_torque_nm": 0.0,
        "charge_soc_band": 0.1, "engine_stop_speed_mps": scalar(p, "cs_electric_decel_spd"),
        "engine_stop_soc_min": scalar(p, "cs_lo_soc"), "restart_energy_j": 2000.0,
        "electrical_aux_power_w": scalar(d / "ACC_INSIGHT.m", "acc_elec_pwr"),
        "fuel_cut_min_speed_rpm": 1000.0, "soc_correction_path_efficiency": 0.85,
        "sources": {
            "soc_target": "the test's initial SOC (69 %, the log's file name)",
            "assist_threshold_nm": f"{src}: cs_dl_assist_trq_threshold",
            "assist_min_nm": f"{src}: cs_mc_assist_min_frac x 46.5 N·m",
            "assist_slope": f"{src}: cs_mc_assist_slope 1/11",
            "assist_max_nm": f"{src}: cs_mc_assist_max_frac x 46.5 N·m",
            "assist_min_gear": f"{ADV}, honda_insight.md: no assist in 1st gear",
            "assist_soc_min": f"{src}: cs_lo_soc",
            "regen_threshold_nm": f"{src}: cs_dl_regen_trq_threshold",
            "regen_fraction": f"{src}: cs_mc_regen_slope",
            "regen_min_speed_mps": f"{src}: cs_decel_regen_threshold 10 mph",
            "regen_soc_max": f"{src}: cs_hi_soc",
            "charge_torque_nm": "engineering choice: no charging by the engine in the SOC "
                                "window of the test",
            "charge_soc_band": "engineering choice",
            "engine_stop_speed_mps": f"{src}: cs_electric_decel_spd",
            "engine_stop_soc_min": f"{src}: cs_lo_soc",
            "restart_energy_j": "engineering estimate: about 4 kW for 0.5 s of cranking",
            "electrical_aux_power_w": f"{ADV}, ACC_INSIGHT.m: acc_elec_pwr (NREL tests)",
            "fuel_cut_min_speed_rpm": "engineering estimate: about idle speed (decel fuel "
                                      "cut, cs_decel_fc_off)",
            "soc_correction_path_efficiency": "engineering estimate of the engine-to-battery "
                                              "path (motor generating, battery charge) used by "
                                              "the SOC correction",
        },
    }


DRIVER = {
    "response_time_s": 0.5, "ki_n_per_m": 50.0, "integrator_limit_n": 1500.0,
    "max_force_n": 8000.0, "tolerance_speed_mph": 2.0, "tolerance_time_s": 1.0,
    "sources": {
        "response_time_s": "engineering choice: speed errors corrected within about 0.5 s",
        "ki_n_per_m": "engineering choice", "integrator_limit_n": "engineering choice",
        "max_force_n": "engineering bound above the powertrain's tractive force",
        "tolerance_speed_mph": "EPA 40 CFR 86.115-78: ±2 mph",
        "tolerance_time_s": "EPA 40 CFR 86.115-78: within ±1 s",
    },
}


def build(d: Path) -> dict:
    """The vehicle file as a dict."""
    body, drive = chassis(d)
    return {
        "architecture": "parallel_hybrid", "name": "insight_2000",
        "description": "2000 Honda Insight (IMA parallel hybrid, 5-speed manual), from the "
                       "ADVISOR 2003 component data (NREL; ADVISOR licence, MIT-style): "
                       "figures only, scaled where stated",
        "transmission": "manual", "body": body, "engine": engine(d), "motor": motor(d),
        "battery": battery(d), "gearbox": gearbox(d, drive), "driveline": drive,
        "controller": controller(d), "driver": DRIVER,
    }


def render(d: Path) -> str:
    head = ("# 2000 Honda Insight for the vehval parallel-hybrid simulator. Generated by\n"
            "# scripts/make_insight.py from the figures of the ADVISOR 2003 Insight data files\n"
            "# (ADVISOR licence, MIT-style); every value's origin is in its block's sources.\n")

    class _NoAlias(yaml.SafeDumper):
        def ignore_aliases(self, data):
            return True

    return head + yaml.dump(build(d), Dumper=_NoAlias, sort_keys=False, width=100,
                            default_flow_style=None, allow_unicode=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ref", help="folder of the ADVISOR Insight reference files")
    ap.add_argument("--check", action="store_true", help="exit 1 when the file is stale")
    a = ap.parse_args(argv)
    d = ref_dir(a.ref)
    if not (d / "FC_INSIGHT.m").exists():
        print(f"make_insight: no ADVISOR Insight files in {d} (give --ref)", file=sys.stderr)
        return 2
    text = render(d)
    if a.check:
        return 0 if OUT.exists() and OUT.read_text() == text else 1
    OUT.write_text(text)
    print(f"wrote {OUT.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
