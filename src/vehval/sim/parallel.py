"""Run the forward-looking simulation of a parallel hybrid over a drive cycle.

The front door (:mod:`vehval.sim.simulate`, its ``ARCHITECTURES`` registry) packs a vehicle
with ``architecture: parallel_hybrid`` with these functions and runs
:func:`vehval.sim.parallel_kernel.run_parallel`. The result is the same ``SimResult`` as the
other architectures': ``<base>_simu`` signals and a summary with fuel, distance, fuel
economy, SOC, engine use, assist / regen time and energy, trace following and the energy
balance.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.fuels import fuel_consumption_l_per_100km, fuel_economy_mpg, fuel_volume_m3
from vehval.sim.layout import PAR_PARAMS, PAR_SUMMARY
from vehval.sim.packing import CHASSIS_FROM_FILE
from vehval.vehicle.parallel import ParallelHybridVehicle

#: layout name (``PAR_PARAMS``) -> (vehicle block, key, factor to SI): read from the file
PAR_FROM_FILE: dict[str, tuple[str, str, float]] = {
    **CHASSIS_FROM_FILE,
    "gb_eff": ("gearbox", "efficiency", 1.0), "shift_time": ("gearbox", "shift_time_s", 1.0),
    "j_eng": ("engine", "inertia_kg_m2", 1.0), "j_mot": ("motor", "inertia_kg_m2", 1.0),
    "eng_idle": ("engine", "idle_speed_rpm", RPM),
    "eng_max_spd": ("engine", "max_speed_rpm", RPM),
    "eng_drag": ("engine", "motoring_torque_nm", 1.0),
    "eng_pmax": ("engine", "max_power_w", 1.0), "fuel_lhv": ("engine", "fuel_lhv_j_per_kg", 1.0),
    "fuel_cut_spd": ("controller", "fuel_cut_min_speed_rpm", RPM),
    "mech_acc": ("body", "aux_power_w", 1.0),
    "elec_acc": ("controller", "electrical_aux_power_w", 1.0),
    "mot_tmax": ("motor", "max_torque_nm", 1.0), "mot_pmax": ("motor", "max_power_w", 1.0),
    "batt_cap_c": ("battery", "capacity_c", 1.0),
    "soc_lo": ("battery", "soc_min", 1.0), "soc_hi": ("battery", "soc_max", 1.0),
    "soc_target": ("controller", "soc_target", 1.0),
    "assist_thr": ("controller", "assist_threshold_nm", 1.0),
    "assist_min": ("controller", "assist_min_nm", 1.0),
    "assist_slope": ("controller", "assist_slope", 1.0),
    "assist_max": ("controller", "assist_max_nm", 1.0),
    "assist_gear": ("controller", "assist_min_gear", 1.0),
    "assist_soc": ("controller", "assist_soc_min", 1.0),
    "regen_thr": ("controller", "regen_threshold_nm", 1.0),
    "regen_frac": ("controller", "regen_fraction", 1.0),
    "regen_spd": ("controller", "regen_min_speed_mps", 1.0),
    "regen_soc": ("controller", "regen_soc_max", 1.0),
    "charge_trq": ("controller", "charge_torque_nm", 1.0),
    "charge_band": ("controller", "charge_soc_band", 1.0),
    "stop_spd": ("controller", "engine_stop_speed_mps", 1.0),
    "stop_soc": ("controller", "engine_stop_soc_min", 1.0),
    "restart_j": ("controller", "restart_energy_j", 1.0),
    "mot_idle_off": ("controller", "motor_off_when_idle", 1.0),
    "drv_tau": ("driver", "response_time_s", 1.0), "drv_ki": ("driver", "ki_n_per_m", 1.0),
    "drv_int_lim": ("driver", "integrator_limit_n", 1.0),
    "drv_fmax": ("driver", "max_force_n", 1.0),
    "warm_tau": ("engine", "warmup_time_constant_s", 1.0),
}
#: layout names :func:`par_param_vector` computes: the coupling capacity and the automatic
#: flag, the warm-up fuel fraction of a cold start, the initial SOC
PAR_COMPUTED = ("tc_k", "automatic", "warm_frac", "soc_init")


def par_param_vector(veh: ParallelHybridVehicle, soc0: float,
                     cold_start: bool = False) -> np.ndarray:
    """Scalar parameters of ``veh`` in SI, in the order of ``PAR_PARAMS`` (``soc0`` [-] the
    initial SOC; ``cold_start``: the vehicle's warm-up fuel applies)."""
    val = {name: getattr(getattr(veh, blk), key) * f
           for name, (blk, key, f) in PAR_FROM_FILE.items()}
    auto = veh.converter is not None
    val.update({"tc_k": veh.converter.capacity_nm_s2_per_rad2 if veh.converter else 1.0,
                "automatic": 1.0 if auto else 0.0,
                "warm_frac": veh.engine.warmup_fuel_fraction if cold_start else 0.0,
                "soc_init": soc0})
    return np.array([float(val[k]) for k in PAR_PARAMS])


def par_maps(veh: ParallelHybridVehicle) -> tuple[np.ndarray, ...]:
    """Engine, motor, battery maps and gearbox tables in SI, in the kernel's order."""
    e, m, b, g = veh.engine.arrays(), veh.motor.arrays(), veh.battery, veh.gearbox
    bat = [np.asarray(x, float) for x in (b.soc, b.ocv_v, b.resistance_discharge_ohm,
                                          b.resistance_charge_ohm, b.discharge_power_limit_w,
                                          b.charge_power_limit_w)]
    lock = (veh.converter.lockup_speed_mps if veh.converter is not None
            else [0.0] * len(g.ratios))
    gb = [np.asarray(x, float) for x in (g.ratios, g.upshift_speed_mps,
                                         g.upshift_speed_full_load_mps, g.downshift_speed_mps,
                                         g.downshift_speed_full_load_mps, lock)]
    return (e["spd"], e["trq"], e["fuel"], e["tmax"], m["spd"], m["trq"], m["loss"], *bat, *gb)


def summarise_parallel(veh: ParallelHybridVehicle, ys: np.ndarray, soc0: float,
                       soc_correction: Callable[..., float]) -> dict:
    """Summary dict from the accumulator vector of the parallel-hybrid loop.

    Keys: every ``PAR_SUMMARY`` entry plus ``soc_initial``, ``soc_delta``,
    ``ess_net_energy_j`` (chemical, + discharged), ``fuel_economy_mpg``,
    ``fuel_consumption_l_per_100km``, their ``*_soc_corrected_*`` forms and
    ``fuel_mass_soc_corrected_kg`` (the simulator's energy-balance correction,
    :func:`vehval.sim.simulate.energy_balance_fuel_kg`), ``engine_mean_efficiency``
    (the best-line efficiency when the engine did not run), ``engine_on_fraction``,
    ``engine_starts``, ``trace_n_miss``, ``gear_shifts`` (int), ``energy_balance_residual_j``
    and ``energy_balance_rel`` (fuel + battery chemical energy against every loss, the
    accessories, the shaft's and the car's kinetic energy change).
    """
    from vehval.vehicle.maps import best_efficiency_line, best_line_efficiency

    s = {k: float(v) for k, v in zip(PAR_SUMMARY, ys)}
    dist, fuel = s["distance_m"], s["fuel_mass_kg"]
    rho = veh.engine.fuel_density_kg_per_m3
    vol = fuel_volume_m3(fuel, rho)
    eta = s["eng_out_energy_j"] / s["fuel_energy_j"] if s["fuel_energy_j"] > 0 else 0.0
    if eta <= 0.0:  # no engine use: the engine's best efficiency
        eta = best_line_efficiency(veh.engine, best_efficiency_line(veh.engine))
    fuel_corr = soc_correction(fuel, s["ess_chem_energy_j"],
                                veh.engine.fuel_lhv_j_per_kg, eta,
                                veh.controller.soc_correction_path_efficiency)
    vol_corr = fuel_volume_m3(fuel_corr, rho)
    sinks = (s["eng_loss_j"] + s["mot_loss_j"] + s["ess_loss_j"] + s["aux_mech_energy_j"]
             + s["aux_elec_energy_j"] + s["restart_loss_j"] + s["shaft_ke_change_j"]
             + s["clutch_loss_j"] + s["gearbox_loss_j"] + s["brake_energy_j"]
             + s["road_energy_j"] + s["ke_end_j"] - s["ke_start_j"])
    sources = s["fuel_energy_j"] + s["ess_chem_energy_j"]
    scale = max(s["fuel_energy_j"] + abs(s["ess_chem_energy_j"]), s["road_energy_j"], 1.0)
    dur = s["duration_s"]
    s.update({
        "soc_initial": float(soc0),
        "soc_delta": s["soc_final"] - soc0,
        "ess_net_energy_j": s["ess_chem_energy_j"],
        "fuel_economy_mpg": fuel_economy_mpg(dist, vol, empty=float("inf")),
        "fuel_consumption_l_per_100km": fuel_consumption_l_per_100km(vol, dist),
        "engine_mean_efficiency": float(eta),
        "fuel_mass_soc_corrected_kg": fuel_corr,
        "fuel_economy_soc_corrected_mpg": fuel_economy_mpg(dist, vol_corr, empty=float("inf")),
        "fuel_consumption_soc_corrected_l_per_100km": fuel_consumption_l_per_100km(vol_corr,
                                                                                   dist),
        "engine_on_fraction": s["eng_on_time_s"] / dur if dur > 0 else 0.0,
        "engine_starts": round(s["engine_starts"]),
        "trace_n_miss": round(s["trace_n_miss"]),
        "gear_shifts": round(s["gear_shifts"]),
        "energy_balance_residual_j": sources - sinks,
        "energy_balance_rel": (sources - sinks) / scale,
    })
    return s
