"""Run the forward-looking simulation of a conventional vehicle over a drive cycle.

The front door (:mod:`vehval.sim.simulate`, its ``ARCHITECTURES`` registry) packs a vehicle
with ``architecture: conventional`` with these functions and runs
:func:`vehval.sim.conventional_kernel.run_conventional`. The result is the same
:class:`SimResult` as the hybrid's: ``<base>_simu`` signals and a summary with fuel,
distance, fuel economy, trace following and the energy balance (fuel economy keys as the
hybrid's; no battery, so no SOC correction).
"""

from __future__ import annotations

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.fuels import fuel_consumption_l_per_100km, fuel_economy_mpg, fuel_volume_m3
from vehval.sim.conventional_kernel import CONV_PARAMS, CONV_SUMMARY
from vehval.sim.packing import CHASSIS_FROM_FILE
from vehval.vehicle.conventional import ConventionalVehicle

#: layout name (``CONV_PARAMS``) -> (vehicle block, key, factor to SI): read from the file
CONV_FROM_FILE: dict[str, tuple[str, str, float]] = {
    **CHASSIS_FROM_FILE,
    "gb_eff": ("gearbox", "efficiency", 1.0), "shift_time": ("gearbox", "shift_time_s", 1.0),
    "tc_k": ("converter", "capacity_nm_s2_per_rad2", 1.0),
    "j_eng": ("engine", "inertia_kg_m2", 1.0), "eng_idle": ("engine", "idle_speed_rpm", RPM),
    "eng_max_spd": ("engine", "max_speed_rpm", RPM),
    "eng_drag": ("engine", "motoring_torque_nm", 1.0),
    "eng_pmax": ("engine", "max_power_w", 1.0), "fuel_lhv": ("engine", "fuel_lhv_j_per_kg", 1.0),
    "idle_fuel": ("engine_control", "idle_fuel_rate_g_per_s", 1e-3),
    "fuel_cut_spd": ("engine_control", "fuel_cut_min_speed_rpm", RPM),
    "overrun_fuel": ("engine_control", "overrun_fuel_rate_g_per_s", 1e-3),
    "drag_a": ("gearbox", "drag_force_n", 1.0), "drag_b": ("gearbox", "drag_force_n_per_mps", 1.0),
    "drv_tau": ("driver", "response_time_s", 1.0), "drv_ki": ("driver", "ki_n_per_m", 1.0),
    "drv_int_lim": ("driver", "integrator_limit_n", 1.0),
    "drv_fmax": ("driver", "max_force_n", 1.0),
    "warm_tau": ("engine", "warmup_time_constant_s", 1.0),
}
#: layout names :func:`conv_param_vector` computes: accessory loads [W] (with the A/C when
#: on; the idle fuel rate's own), the warm-up fuel fraction of a cold start
CONV_COMPUTED = ("acc_pwr", "idle_acc_pwr", "warm_frac")


def conv_param_vector(veh: ConventionalVehicle, cold_start: bool = False) -> np.ndarray:
    """Scalar parameters of ``veh`` in SI, in the order of ``CONV_PARAMS`` (``cold_start``:
    the run starts with a cold engine, the vehicle's warm-up fuel applies)."""
    c = veh.engine_control
    acc = c.accessory_power_w + veh.body.aux_power_w  # [W] what the idle fuel rate includes
    val = {name: getattr(getattr(veh, blk), key) * f
           for name, (blk, key, f) in CONV_FROM_FILE.items()}
    val.update({"acc_pwr": acc + (c.ac_power_w if c.ac_on else 0.0), "idle_acc_pwr": acc,
                "warm_frac": veh.engine.warmup_fuel_fraction if cold_start else 0.0})
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
