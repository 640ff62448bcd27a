"""A small, fully specified conventional vehicle for the simulator tests (built in code)."""

import numpy as np

from vehval.vehicle import ConventionalVehicle


def _src(keys):
    return {k: "test value" for k in keys}


def conventional_dict(**changes) -> dict:
    """Vehicle-file mapping of a 1500 kg car with a 6-speed automatic (test values)."""
    spd = [600.0, 1000.0, 1500.0, 2000.0, 2500.0, 3000.0, 3500.0, 4500.0]
    trq = [0.0, 50.0, 100.0, 150.0, 200.0, 250.0, 300.0, 350.0]
    w = np.asarray(spd) * np.pi / 30
    # Willans map: friction fuel rising with speed + 1 / (0.42 · 42.8 MJ/kg) per W of power
    fuel = [[float(1e3 * (2e-5 * wi / 100 + 0.8e-4 * (wi / 100) ** 2 + ti * wi / (0.42 * 42.8e6)))
             for ti in trq] for wi in w]
    d = {
        "architecture": "conventional", "name": "test_conventional",
        "body": {"mass_kg": 1500.0, "road_load_a_n": 100.0, "road_load_b_n_per_mps": 2.0,
                 "road_load_c_n_per_mps2": 0.4, "aux_power_w": 0.0},
        "engine": {"speed_rpm": spd, "torque_nm": trq, "fuel_rate_g_per_s": fuel,
                   "max_torque_nm": [150, 250, 330, 350, 350, 320, 290, 230],
                   "max_power_w": 110000.0, "max_speed_rpm": 4500.0, "idle_speed_rpm": 800.0,
                   "fire_speed_rpm": 400.0, "motoring_torque_nm": 25.0, "inertia_kg_m2": 0.2,
                   "fuel_density_kg_per_m3": 840.0, "fuel_lhv_j_per_kg": 42.8e6},
        "engine_control": {"idle_fuel_rate_g_per_s": 0.18, "fuel_cut_min_speed_rpm": 1000.0,
                           "overrun_fuel_rate_g_per_s": 0.0, "accessory_power_w": 300.0},
        "gearbox": {"ratios": [4.0, 2.4, 1.55, 1.15, 0.86, 0.68], "efficiency": 0.95,
                    "upshift_speed_mps": [4.0, 7.0, 10.0, 14.0, 18.0],
                    "upshift_speed_full_load_mps": [7.0, 12.0, 17.0, 23.0, 29.0],
                    "downshift_speed_mps": [2.0, 4.5, 7.5, 11.0, 15.0],
                    "downshift_speed_full_load_mps": [4.0, 8.0, 12.0, 17.0, 22.0],
                    "shift_time_s": 0.5},
        "converter": {"capacity_nm_s2_per_rad2": 0.01,
                      "lockup_speed_mps": [30.0, 6.0, 8.0, 10.0, 12.0, 14.0]},
        "driveline": {"final_drive_ratio": 3.0, "final_drive_efficiency": 0.98,
                      "wheel_radius_m": 0.31, "wheel_inertia_kg_m2": 1.5,
                      "brake_max_force_n": 15000.0},
        "driver": {"response_time_s": 0.5, "ki_n_per_m": 50.0, "integrator_limit_n": 1500.0,
                   "max_force_n": 9000.0, "tolerance_speed_mph": 2.0, "tolerance_time_s": 1.0},
    }
    for blk in ("body", "engine", "engine_control", "gearbox", "converter", "driveline",
                "driver"):
        d[blk]["sources"] = _src(d[blk])
    for path, val in changes.items():
        blk, key = path.split(".")
        d[blk][key] = val
        d[blk]["sources"].setdefault(key, "test value")
    return d


def conventional_vehicle(**changes) -> ConventionalVehicle:
    return ConventionalVehicle.model_validate(conventional_dict(**changes))
