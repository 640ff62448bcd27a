"""Pack a :class:`~vehval.vehicle.Vehicle` into the flat arrays of the compiled loop."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.sim.layout import PARAMS
from vehval.vehicle import Vehicle

MAP_NAMES = ("eng_spd", "eng_trq", "eng_fuel", "eng_tmax", "opt_pwr", "opt_spd",
             "mot_spd", "mot_trq", "mot_loss", "gen_spd", "gen_trq", "gen_loss",
             "bat_soc", "bat_ocv", "bat_rdis", "bat_rchg", "bat_pdis", "bat_pchg")


@dataclass
class Packed:
    """Scalar parameter vector (``PARAMS`` order) and the map arrays (``MAP_NAMES`` order)."""

    prm: np.ndarray
    maps: tuple[np.ndarray, ...]


def best_engine_efficiency(veh: Vehicle) -> float:
    """Highest efficiency [-] on the engine's best-efficiency line (from the fuel map)."""
    from vehval.vehicle.maps import bilinear

    p, w, t = veh.best_line
    a = veh.engine.arrays()
    fuel = bilinear(a["spd"], a["trq"], a["fuel"], w, t)
    ok = (p > 0) & (fuel > 0)
    return float(np.max(p[ok] / (fuel[ok] * veh.engine.fuel_lhv_j_per_kg)))


def param_vector(veh: Vehicle, soc_initial: float, cold_start: bool = False) -> np.ndarray:
    """Scalar parameters of ``veh`` in SI, in the order of :data:`vehval.sim.layout.PARAMS`.

    ``cold_start``: the run starts with a cold engine (the vehicle's warm-up fuel and
    engine-on hold apply; both are 0 in a vehicle without a cold-start model)."""
    b, e, g1, g2, bt = veh.body, veh.engine, veh.mg1, veh.mg2, veh.battery
    d, pg, bo, c, dr = veh.driveline, veh.planetary, veh.boost, veh.controller, veh.driver
    val = {
        "mass": b.mass_kg, "rl_a": b.road_load_a_n, "rl_b": b.road_load_b_n_per_mps,
        "rl_c": b.road_load_c_n_per_mps2, "aux_w": b.aux_power_w,
        "r_wheel": d.wheel_radius_m, "fd_ratio": d.final_drive_ratio,
        "fd_eff": d.final_drive_efficiency, "j_wheel": d.wheel_inertia_kg_m2,
        "brk_max": d.brake_max_force_n, "n_sun": pg.sun_teeth, "n_ring": pg.ring_teeth,
        "j_carrier": pg.carrier_inertia_kg_m2, "j_ring": pg.ring_inertia_kg_m2,
        "j_eng": e.inertia_kg_m2, "eng_idle": e.idle_speed_rpm * RPM,
        "eng_max_spd": e.max_speed_rpm * RPM, "eng_fire": e.fire_speed_rpm * RPM,
        "eng_drag": e.motoring_torque_nm, "eng_pmax": e.max_power_w,
        "fuel_lhv": e.fuel_lhv_j_per_kg,
        "mot_tmax": g2.max_torque_nm, "mot_pmax": g2.max_power_w,
        "mot_max_spd": g2.max_speed_rpm * RPM, "j_mot": g2.inertia_kg_m2,
        "gen_tmax": g1.max_torque_nm, "gen_pmax": g1.max_power_w,
        "gen_max_spd": g1.max_speed_rpm * RPM, "j_gen": g1.inertia_kg_m2,
        "batt_cap_c": bt.capacity_c, "boost_eff": bo.efficiency,
        "boost_vmax": bo.volt_out_max_v, "boost_vmin": bo.volt_out_min_v,
        "boost_full_spd": bo.volt_full_speed_rpm * RPM,
        "soc_target": c.soc_target, "soc_gain": c.soc_gain_w,
        "soc_pchg_max": c.soc_charge_power_max_w, "soc_pdis_max": c.soc_discharge_power_max_w,
        "on_pwr": c.engine_on_power_w, "on_pwr_hold": c.engine_on_power_hold_s,
        "off_pwr": c.engine_off_power_w, "on_spd": c.engine_on_speed_mps,
        "on_spd_hold": c.engine_on_speed_hold_s, "off_spd": c.engine_off_speed_mps,
        "batt_hold": c.battery_condition_hold_s, "elec_eff": c.electric_drive_efficiency,
        "off_hold": c.engine_off_hold_s, "soc_on": c.soc_engine_on,
        "soc_on_hold": c.soc_engine_on_hold_s, "soc_force": c.soc_force_on,
        "min_on": c.min_on_time_s, "min_off": c.min_off_time_s,
        "dis_margin": c.battery_discharge_margin_w, "chg_margin": c.battery_charge_margin_w,
        "eng_min_pwr": c.engine_min_power_w, "fuel_cut_pwr": c.fuel_cut_power_w,
        "fuel_cut_spd": c.fuel_cut_min_speed_mps, "regen_frac": c.regen_fraction_max,
        "fade_lo": c.regen_fade_low_mps, "fade_hi": c.regen_fade_high_mps,
        "gen_kp": c.gen_speed_kp_nm_per_radps, "gen_ki": c.gen_speed_ki_nm_per_rad,
        "eng_pwr_tau": c.engine_power_filter_s,
        "gen_spd_margin": c.gen_speed_margin_rpm * RPM,
        "eng_spd_margin": c.engine_speed_margin_rpm * RPM,
        "drv_tau": dr.response_time_s, "drv_ki": dr.ki_n_per_m,
        "drv_int_lim": dr.integrator_limit_n, "drv_fmax": dr.max_force_n,
        "soc_init": soc_initial, "mg2_ratio": d.mg2_reduction_ratio,
        "op_system": 1.0 if c.operating_point == "system" else 0.0,
        "eq_factor": 1.0 / (best_engine_efficiency(veh) * c.soc_correction_path_efficiency),
        "cold_start": 1.0 if cold_start else 0.0, "cold_hold": c.cold_start_engine_on_s,
        "warm_frac": e.warmup_fuel_fraction, "warm_tau": e.warmup_time_constant_s,
        "cold_pwr": c.cold_start_engine_power_w,
    }
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
