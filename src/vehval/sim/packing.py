"""Pack a :class:`~vehval.vehicle.Vehicle` into the flat arrays of the compiled loop."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.sim.layout import PARAMS
from vehval.vehicle import Vehicle
from vehval.vehicle.maps import best_line_efficiency

MAP_NAMES = ("eng_spd", "eng_trq", "eng_fuel", "eng_tmax", "opt_pwr", "opt_spd",
             "mot_spd", "mot_trq", "mot_loss", "gen_spd", "gen_trq", "gen_loss",
             "bat_soc", "bat_ocv", "bat_rdis", "bat_rchg", "bat_pdis", "bat_pchg")


@dataclass
class Packed:
    """Scalar parameter vector (``PARAMS`` order) and the map arrays (``MAP_NAMES`` order)."""

    prm: np.ndarray
    maps: tuple[np.ndarray, ...]


#: layout name -> (vehicle block, key, factor to SI): the parameters read from the file
#: The chassis keys every architecture reads: body and driveline to the wheels.
CHASSIS_FROM_FILE: dict[str, tuple[str, str, float]] = {
    "mass": ("body", "mass_kg", 1.0), "rl_a": ("body", "road_load_a_n", 1.0),
    "rl_b": ("body", "road_load_b_n_per_mps", 1.0),
    "rl_c": ("body", "road_load_c_n_per_mps2", 1.0),
    "r_wheel": ("driveline", "wheel_radius_m", 1.0),
    "fd_ratio": ("driveline", "final_drive_ratio", 1.0),
    "fd_eff": ("driveline", "final_drive_efficiency", 1.0),
    "j_wheel": ("driveline", "wheel_inertia_kg_m2", 1.0),
    "brk_max": ("driveline", "brake_max_force_n", 1.0),
}

FROM_FILE: dict[str, tuple[str, str, float]] = {
    **CHASSIS_FROM_FILE, "aux_w": ("body", "aux_power_w", 1.0),
    "n_sun": ("planetary", "sun_teeth", 1.0), "n_ring": ("planetary", "ring_teeth", 1.0),
    "j_carrier": ("planetary", "carrier_inertia_kg_m2", 1.0),
    "j_ring": ("planetary", "ring_inertia_kg_m2", 1.0),
    "j_eng": ("engine", "inertia_kg_m2", 1.0), "eng_idle": ("engine", "idle_speed_rpm", RPM),
    "eng_max_spd": ("engine", "max_speed_rpm", RPM),
    "eng_fire": ("engine", "fire_speed_rpm", RPM),
    "eng_drag": ("engine", "motoring_torque_nm", 1.0),
    "eng_pmax": ("engine", "max_power_w", 1.0), "fuel_lhv": ("engine", "fuel_lhv_j_per_kg", 1.0),
    "mot_tmax": ("mg2", "max_torque_nm", 1.0), "mot_pmax": ("mg2", "max_power_w", 1.0),
    "mot_max_spd": ("mg2", "max_speed_rpm", RPM), "j_mot": ("mg2", "inertia_kg_m2", 1.0),
    "gen_tmax": ("mg1", "max_torque_nm", 1.0), "gen_pmax": ("mg1", "max_power_w", 1.0),
    "gen_max_spd": ("mg1", "max_speed_rpm", RPM), "j_gen": ("mg1", "inertia_kg_m2", 1.0),
    "batt_cap_c": ("battery", "capacity_c", 1.0), "boost_eff": ("boost", "efficiency", 1.0),
    "boost_vmax": ("boost", "volt_out_max_v", 1.0), "boost_vmin": ("boost", "volt_out_min_v", 1.0),
    "boost_full_spd": ("boost", "volt_full_speed_rpm", RPM),
    "soc_target": ("controller", "soc_target", 1.0),
    "soc_gain": ("controller", "soc_gain_w", 1.0),
    "soc_pchg_max": ("controller", "soc_charge_power_max_w", 1.0),
    "soc_pdis_max": ("controller", "soc_discharge_power_max_w", 1.0),
    "on_pwr": ("controller", "engine_on_power_w", 1.0),
    "on_pwr_hold": ("controller", "engine_on_power_hold_s", 1.0),
    "off_pwr": ("controller", "engine_off_power_w", 1.0),
    "on_spd": ("controller", "engine_on_speed_mps", 1.0),
    "on_spd_hold": ("controller", "engine_on_speed_hold_s", 1.0),
    "off_spd": ("controller", "engine_off_speed_mps", 1.0),
    "batt_hold": ("controller", "battery_condition_hold_s", 1.0),
    "elec_eff": ("controller", "electric_drive_efficiency", 1.0),
    "off_hold": ("controller", "engine_off_hold_s", 1.0),
    "soc_on": ("controller", "soc_engine_on", 1.0),
    "soc_on_hold": ("controller", "soc_engine_on_hold_s", 1.0),
    "soc_force": ("controller", "soc_force_on", 1.0),
    "min_on": ("controller", "min_on_time_s", 1.0),
    "min_off": ("controller", "min_off_time_s", 1.0),
    "dis_margin": ("controller", "battery_discharge_margin_w", 1.0),
    "chg_margin": ("controller", "battery_charge_margin_w", 1.0),
    "eng_min_pwr": ("controller", "engine_min_power_w", 1.0),
    "fuel_cut_pwr": ("controller", "fuel_cut_power_w", 1.0),
    "fuel_cut_spd": ("controller", "fuel_cut_min_speed_mps", 1.0),
    "regen_frac": ("controller", "regen_fraction_max", 1.0),
    "fade_lo": ("controller", "regen_fade_low_mps", 1.0),
    "fade_hi": ("controller", "regen_fade_high_mps", 1.0),
    "gen_kp": ("controller", "gen_speed_kp_nm_per_radps", 1.0),
    "gen_ki": ("controller", "gen_speed_ki_nm_per_rad", 1.0),
    "eng_pwr_tau": ("controller", "engine_power_filter_s", 1.0),
    "gen_spd_margin": ("controller", "gen_speed_margin_rpm", RPM),
    "eng_spd_margin": ("controller", "engine_speed_margin_rpm", RPM),
    "drv_tau": ("driver", "response_time_s", 1.0), "drv_ki": ("driver", "ki_n_per_m", 1.0),
    "drv_int_lim": ("driver", "integrator_limit_n", 1.0),
    "drv_fmax": ("driver", "max_force_n", 1.0),
    "mg2_ratio": ("driveline", "mg2_reduction_ratio", 1.0),
    "cold_hold": ("controller", "cold_start_engine_on_s", 1.0),
    "warm_frac": ("engine", "warmup_fuel_fraction", 1.0),
    "warm_tau": ("engine", "warmup_time_constant_s", 1.0),
    "cold_pwr": ("controller", "cold_start_engine_power_w", 1.0),
}
#: layout names :func:`param_vector` computes (run options and derived values)
COMPUTED = ("soc_init", "op_system", "eq_factor", "cold_start")


def param_vector(veh: Vehicle, soc_initial: float, cold_start: bool = False) -> np.ndarray:
    """Scalar parameters of ``veh`` in SI, in the order of :data:`vehval.sim.layout.PARAMS`.

    Every entry is a vehicle-file key (:data:`FROM_FILE`) or one of :data:`COMPUTED`:
    ``soc_init`` the initial SOC [-], ``op_system`` 1 for the ``system`` operating point,
    ``eq_factor`` fuel energy per battery chemical energy [-], ``cold_start`` 1 when the run
    starts with a cold engine (the vehicle's warm-up fuel and engine-on hold apply; both
    are 0 in a vehicle without a cold-start model)."""
    c = veh.controller
    val = {name: getattr(getattr(veh, blk), key) * f for name, (blk, key, f) in FROM_FILE.items()}
    val.update({
        "soc_init": soc_initial,
        "op_system": 1.0 if c.operating_point == "system" else 0.0,
        "eq_factor": 1.0 / (best_line_efficiency(veh.engine, veh.best_line)
                           * c.soc_correction_path_efficiency),
        "cold_start": 1.0 if cold_start else 0.0,
    })
    return np.array([float(val[k]) for k in PARAMS])


def pack(veh: Vehicle, soc_initial: float, cold_start: bool = False) -> Packed:
    """Parameter vector and SI map arrays for :func:`vehval.sim.kernel.run`."""
    e = veh.engine.arrays()
    m2 = veh.mg2.arrays()
    m1 = veh.mg1.arrays()
    bt = veh.battery
    opt_p, opt_w, _ = veh.best_line
    arrs = (e["spd"], e["trq"], e["fuel"], e["tmax"], opt_p, opt_w,
            m2["spd"], m2["trq"], m2["loss"], m1["spd"], m1["trq"], m1["loss"],
            bt.soc, bt.ocv_v, bt.resistance_discharge_ohm, bt.resistance_charge_ohm,
            bt.discharge_power_limit_w, bt.charge_power_limit_w)
    maps = tuple(np.ascontiguousarray(np.asarray(a, dtype=np.float64)) for a in arrs)
    return Packed(param_vector(veh, soc_initial, cold_start), maps)
