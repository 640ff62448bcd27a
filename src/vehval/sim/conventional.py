"""Run the forward-looking simulation of a conventional vehicle over a drive cycle.

:func:`vehval.sim.simulate.simulate` dispatches here when the vehicle file says
``architecture: conventional``. The result is the same :class:`SimResult` as the hybrid's:
``<base>_simu`` signals and a summary with fuel, distance, fuel economy, trace following and
the energy balance (fuel economy keys as the hybrid's; no battery, so no SOC correction).
"""

from __future__ import annotations

import numpy as np

from vehval.constants import MPH_M_PER_S
from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.fuels import fuel_consumption_l_per_100km, fuel_economy_mpg, fuel_volume_m3
from vehval.sim.conventional_kernel import (
    CONV_PARAMS,
    CONV_SIGNALS,
    CONV_SUMMARY,
    run_conventional,
)
from vehval.sim.driver import tolerance_band
from vehval.vehicle.conventional import ConventionalVehicle


def conv_param_vector(veh: ConventionalVehicle, cold_start: bool = False) -> np.ndarray:
    """Scalar parameters of ``veh`` in SI, in the order of ``CONV_PARAMS`` (``cold_start``:
    the run starts with a cold engine, the vehicle's warm-up fuel applies)."""
    b, e, c, g, d, dr = (veh.body, veh.engine, veh.engine_control, veh.gearbox, veh.driveline,
                         veh.driver)
    acc = c.accessory_power_w + b.aux_power_w  # [W] what the idle fuel rate includes
    val = {
        "mass": b.mass_kg, "rl_a": b.road_load_a_n, "rl_b": b.road_load_b_n_per_mps,
        "rl_c": b.road_load_c_n_per_mps2, "r_wheel": d.wheel_radius_m,
        "fd_ratio": d.final_drive_ratio, "fd_eff": d.final_drive_efficiency,
        "j_wheel": d.wheel_inertia_kg_m2, "brk_max": d.brake_max_force_n,
        "gb_eff": g.efficiency, "shift_time": g.shift_time_s,
        "tc_k": veh.converter.capacity_nm_s2_per_rad2, "j_eng": e.inertia_kg_m2,
        "eng_idle": e.idle_speed_rpm * RPM, "eng_max_spd": e.max_speed_rpm * RPM,
        "eng_drag": e.motoring_torque_nm, "eng_pmax": e.max_power_w,
        "fuel_lhv": e.fuel_lhv_j_per_kg, "idle_fuel": c.idle_fuel_rate_g_per_s * 1e-3,
        "fuel_cut_spd": c.fuel_cut_min_speed_rpm * RPM,
        "overrun_fuel": c.overrun_fuel_rate_g_per_s * 1e-3,
        "acc_pwr": acc + (c.ac_power_w if c.ac_on else 0.0), "idle_acc_pwr": acc,
        "drag_a": g.drag_force_n, "drag_b": g.drag_force_n_per_mps,
        "drv_tau": dr.response_time_s, "drv_ki": dr.ki_n_per_m,
        "drv_int_lim": dr.integrator_limit_n, "drv_fmax": dr.max_force_n,
        "warm_frac": e.warmup_fuel_fraction if cold_start else 0.0,
        "warm_tau": e.warmup_time_constant_s,
    }
    return np.array([float(val[k]) for k in CONV_PARAMS])


def conv_maps(veh: ConventionalVehicle) -> tuple[np.ndarray, ...]:
    """Engine maps and gearbox tables in SI, in the order the kernel takes them."""
    m = veh.engine.arrays()
    g = veh.gearbox
    arr = [np.asarray(x, float) for x in (g.ratios, g.upshift_speed_mps,
                                          g.upshift_speed_full_load_mps, g.downshift_speed_mps,
                                          g.downshift_speed_full_load_mps,
                                          veh.converter.lockup_speed_mps)]
    return (m["spd"], m["trq"], m["fuel"], m["tmax"], *arr)


def run_conventional_once(veh: ConventionalVehicle, t: np.ndarray, vt: np.ndarray, dt: float,
                          record: bool = True,
                          cold_start: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Run the compiled loop once; returns (signals[n, len(CONV_SIGNALS)], summary vector).
    ``cold_start``: the run starts with a cold engine (the vehicle's warm-up fuel)."""
    lo, hi = tolerance_band(t, vt, veh.driver.tolerance_speed_mph * MPH_M_PER_S,
                            veh.driver.tolerance_time_s)
    out = np.zeros((t.size if record else 1, len(CONV_SIGNALS)))
    ys = run_conventional(vt, lo, hi, dt, conv_param_vector(veh, cold_start), *conv_maps(veh), out, record)
    return out, ys


def summarise_conventional(veh: ConventionalVehicle, ys: np.ndarray) -> dict:
    """Summary dict from the accumulator vector of the conventional loop.

    Keys: every ``CONV_SUMMARY`` entry plus ``fuel_economy_mpg``,
    ``fuel_consumption_l_per_100km``, ``engine_mean_efficiency``, ``trace_n_miss`` (int),
    ``gear_shifts`` (int), ``energy_balance_residual_j`` and ``energy_balance_rel`` (fuel
    energy against engine loss, accessories, engine inertia, converter, gearbox, brakes, road
    load and the kinetic energy change).
    """
    s = {k: float(v) for k, v in zip(CONV_SUMMARY, ys)}
    dist, fuel = s["distance_m"], s["fuel_mass_kg"]
    vol = fuel_volume_m3(fuel, veh.engine.fuel_density_kg_per_m3)
    sinks = (s["eng_loss_j"] + s["aux_energy_j"] + s["eng_ke_change_j"] + s["converter_loss_j"]
             + s["gearbox_loss_j"] + s["brake_energy_j"] + s["road_energy_j"] + s["ke_end_j"]
             - s["ke_start_j"])
    scale = max(s["fuel_energy_j"], s["road_energy_j"], 1.0)
    pos = s["eng_out_energy_j"]
    s.update({
        "fuel_economy_mpg": fuel_economy_mpg(dist, vol, empty=float("inf")),
        "fuel_consumption_l_per_100km": fuel_consumption_l_per_100km(vol, dist),
        "engine_mean_efficiency": pos / s["fuel_energy_j"] if s["fuel_energy_j"] > 0 else 0.0,
        "trace_n_miss": round(s["trace_n_miss"]),
        "gear_shifts": round(s["gear_shifts"]),
        "energy_balance_residual_j": s["fuel_energy_j"] - sinks,
        "energy_balance_rel": (s["fuel_energy_j"] - sinks) / scale,
    })
    return s
