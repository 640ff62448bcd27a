"""A battery-electric vehicle file from a few ratings plus generic maps.

:func:`bev_vehicle_data` builds the vehicle-file mapping (``architecture:
battery_electric``) from what a spec sheet or a Test Car List row gives (test mass, road
load, motor peak power and torque, reduction ratio, wheel radius, pack energy and voltage)
and fills the rest with the generic values of :data:`GENERIC`, each with its source. A
caller passes the sources of its own values; every parameter stays sourced.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.vehicle.bev import generic_motor_block

_EST = "engineering estimate (generic BEV, vehval.vehicle.bev_generic)"

#: Generic values (value, source) of what a sheet or list row rarely gives.
GENERIC: dict[str, tuple[Any, str]] = {
    "max_speed_rpm": (10_500.0, _EST + ": typical traction-motor maximum speed of 2011-2019 "
                      "BEVs (Leaf 10,390 rpm, Bolt 8,810 rpm, i3 11,400 rpm)"),
    "motor_inertia_kg_m2": (0.04, _EST + ": rotor inertia of an 80-150 kW PM machine"),
    "final_drive_efficiency": (0.97, _EST + ": single-stage helical reduction and "
                               "differential (FASTSim trans_eff 0.98)"),
    "wheel_inertia_kg_m2": (3.2, _EST + ": four 16-17 in wheels with tyres"),
    "brake_max_force_n": (15_000.0, _EST + ": friction brakes, about 1 g on a 1.5 t car"),
    "aux_power_w": (300.0, _EST + ": 12 V loads, pumps and controllers on the dyno "
                    "(FASTSim aux_kw 0.25-0.7)"),
    "regen_max_power_w": (60_000.0, _EST + ": electric braking limit at the wheels"),
    "fade_low_mps": (1.0, _EST + ": regeneration stops below about 2 mph"),
    "fade_high_mps": (4.0, _EST + ": full regeneration above about 9 mph"),
    "driven_axle_share": (0.9, _EST + ": a 2WD car on a two-axle dyno brakes mostly "
                          "electrically on the driven axle (blended brakes)"),
    "charger_efficiency": (0.88, _EST + ": level-2 on-board charger, wall to battery "
                           "including charge losses (FASTSim assumes 0.86; SAE J1634 "
                           "measures AC energy)"),
    "motor_loss_scale": (0.233, "fitted: the one generic value fitted on the EPA Test Car "
                         "List, on the 26 battery-electric rows of the 2019 list built from "
                         "each row alone (mean MPGe error zero); held out on the 58 rows of "
                         "the 2016 list: mean -0.7 %, sd 14.5 % (scripts/bev_list_validation"
                         ".py, docs/validation.md). A lumped correction of the 2004 machine's "
                         "losses and of what the model leaves out, not a motor measurement"),
    "soc_initial": (0.95, _EST + ": a J1634 test starts from a full charge"),
    "cell_resistance_ohm_ah": (0.060, _EST + ": cell DC resistance x capacity of a "
                               "lithium-ion EV cell (about 1.5 mOhm for a 40 Ah cell)"),
}

#: Generic lithium-ion (NMC/LMO) cell open-circuit voltage [V] over SOC [-].
CELL_SOC = [0.0, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]
CELL_OCV_V = [3.30, 3.45, 3.53, 3.60, 3.65, 3.70, 3.75, 3.82, 3.90, 3.98, 4.07, 4.15]
CELL_OCV_SOURCE = (_EST + ": OCV shape of published NMC/LMO EV cells (3.3 V empty, "
                   "3.75 V at 50 % SOC, 4.15 V full), scaled to the pack's cells in series")


def bev_vehicle_data(*, name: str, description: str, values: dict[str, Any],
                     sources: dict[str, str]) -> dict[str, Any]:
    """A ``battery_electric`` vehicle-file mapping.

    ``values`` must hold ``mass_kg``, ``road_load_a_n``, ``road_load_b_n_per_mps``,
    ``road_load_c_n_per_mps2``, ``max_power_w``, ``max_torque_nm``, ``final_drive_ratio``,
    ``wheel_radius_m``, ``battery_kwh`` (gross pack energy) and ``cells_series``; it may
    hold any key of :data:`GENERIC` and ``cells_parallel``, ``soc_min``, ``soc_max``,
    ``battery_power_w``. ``sources`` gives the source of every value passed.
    """
    val = {k: v for k, (v, _) in GENERIC.items()}
    src = {k: s for k, (_, s) in GENERIC.items()}
    val.update(values)
    src.update(sources)
    missing = [k for k in values if k not in sources]
    if missing:
        raise ValueError(f"values without a source: {', '.join(missing)}")
    val.setdefault("soc_min", 0.05)
    src.setdefault("soc_min", _EST + ": usable window 5-95 % of the gross energy (FASTSim)")
    val.setdefault("soc_max", 0.97)
    src.setdefault("soc_max", _EST + ": the pack is charged close to its top")
    val.setdefault("battery_power_w", 1.25 * val["max_power_w"])
    src.setdefault("battery_power_w", _EST + ": pack power 1.25 x motor peak power")
    ns = int(val["cells_series"])
    ocv = [round(ns * x, 2) for x in CELL_OCV_V]
    nominal = ns * 3.70
    cap_ah = float(val["battery_kwh"]) * 1000.0 / nominal
    r = round(ns * val["cell_resistance_ohm_ah"] / cap_ah, 5)
    n_soc = len(CELL_SOC)
    taper_lo = np.interp(CELL_SOC, [0.0, 0.1, 1.0], [0.3, 1.0, 1.0])
    taper_hi = np.interp(CELL_SOC, [0.0, 0.8, 1.0], [1.0, 1.0, 0.3])
    bsrc = src["battery_kwh"]
    battery = {
        "soc": CELL_SOC, "ocv_v": ocv,
        "resistance_discharge_ohm": [r] * n_soc, "resistance_charge_ohm": [r] * n_soc,
        "discharge_power_limit_w": [round(float(val["battery_power_w"] * x)) for x in taper_lo],
        "charge_power_limit_w": [round(float(val["regen_max_power_w"] * 1.1 * x))
                                 for x in taper_hi],
        "capacity_ah": round(cap_ah, 3), "n_cells": ns, "n_modules": 1,
        "nominal_voltage_v": round(nominal, 1), "soc_min": val["soc_min"],
        "soc_max": val["soc_max"], "chemistry": "li_ion",
        "sources": {
            "soc": "breakpoints of the generic cell OCV curve", "ocv_v": CELL_OCV_SOURCE
            + f" ({ns} cells in series: {src['cells_series']})",
            "resistance_discharge_ohm": src["cell_resistance_ohm_ah"]
            + f"; pack = {ns} in series / capacity",
            "resistance_charge_ohm": src["cell_resistance_ohm_ah"] + "; same as discharge",
            "discharge_power_limit_w": src["battery_power_w"] + "; tapers below 10 % SOC",
            "charge_power_limit_w": src["regen_max_power_w"] + "; x 1.1, tapers above 80 % SOC",
            "capacity_ah": f"computed: pack energy / ({ns} x 3.70 V); energy: {bsrc}",
            "n_cells": src["cells_series"], "n_modules": "one string (modules not modelled)",
            "nominal_voltage_v": f"computed: {ns} cells x 3.70 V", "soc_min": src["soc_min"],
            "soc_max": src["soc_max"], "chemistry": "lithium-ion (all BEVs of the lists)"},
    }
    motor = generic_motor_block(
        float(val["max_power_w"]), float(val["max_torque_nm"]), float(val["max_speed_rpm"]),
        float(val["motor_inertia_kg_m2"]),
        {k: src[s] for k, s in (("max_power_w", "max_power_w"), ("max_torque_nm", "max_torque_nm"),
                                ("max_speed_rpm", "max_speed_rpm"),
                                ("inertia_kg_m2", "motor_inertia_kg_m2"))},
        loss_scale=float(val["motor_loss_scale"]), loss_scale_source=src["motor_loss_scale"])
    body_keys = ("mass_kg", "road_load_a_n", "road_load_b_n_per_mps", "road_load_c_n_per_mps2",
                 "aux_power_w")
    dl_keys = ("final_drive_ratio", "final_drive_efficiency", "wheel_radius_m",
               "wheel_inertia_kg_m2", "brake_max_force_n")
    return {
        "architecture": "battery_electric", "name": name, "description": description,
        "body": {**{k: float(val[k]) for k in body_keys},
                 "sources": {k: src[k] for k in body_keys}},
        "battery": battery, "motor": motor,
        "driveline": {**{k: float(val[k]) for k in dl_keys},
                      "sources": {k: src[k] for k in dl_keys}},
        "regen": {"max_power_w": float(val["regen_max_power_w"]),
                  "fade_low_mps": float(val["fade_low_mps"]),
                  "fade_high_mps": float(val["fade_high_mps"]),
                  "driven_axle_share": float(val["driven_axle_share"]),
                  "sources": {"max_power_w": src["regen_max_power_w"],
                              "fade_low_mps": src["fade_low_mps"],
                              "fade_high_mps": src["fade_high_mps"],
                              "driven_axle_share": src["driven_axle_share"]}},
        "charger": {"efficiency": float(val["charger_efficiency"]),
                    "soc_initial": float(val["soc_initial"]),
                    "sources": {"efficiency": src["charger_efficiency"],
                                "soc_initial": src["soc_initial"]}},
        "driver": dict(GENERIC_DRIVER),
    }


#: The speed follower of the shipped vehicles (the conventional Cruze's driver block).
GENERIC_DRIVER: dict[str, Any] = {
    "response_time_s": 0.5, "ki_n_per_m": 50.0, "integrator_limit_n": 1500.0,
    "max_force_n": 20_000.0, "tolerance_speed_mph": 2.0, "tolerance_time_s": 1.0,
    "sources": {"response_time_s": "engineering choice: speed errors corrected within about "
                "0.5 s", "ki_n_per_m": "engineering choice",
                "integrator_limit_n": "engineering choice",
                "max_force_n": "engineering bound above the powertrain's tractive force",
                "tolerance_speed_mph": "EPA 40 CFR 86.115-78: +-2 mph",
                "tolerance_time_s": "EPA 40 CFR 86.115-78: within +-1 s"},
}
