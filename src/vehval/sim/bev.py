"""Run the forward-looking simulation of a battery-electric vehicle over a drive cycle.

The front door (:mod:`vehval.sim.simulate`, its ``ARCHITECTURES`` registry) packs a vehicle
with ``architecture: battery_electric`` with these functions and runs
:func:`vehval.sim.bev_kernel.run_bev`. The summary holds the battery's DC energy (terminal
``∫ V I dt``, the quantity SAE J1634 measures), the AC (wall) energy through the charger
efficiency, consumption per distance, MPGe, regenerated energy, SOC and the energy balance.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.fuels.quantities import ac_energy_j, kwh_per_100km, kwh_per_100mi, mpge, wh_per_mile
from vehval.sim.layout import BEV_PARAMS, BEV_SUMMARY
from vehval.sim.packing import CHASSIS_FROM_FILE
from vehval.vehicle.bev import BatteryElectricVehicle

#: layout name (``BEV_PARAMS``) -> (vehicle block, key, factor to SI): read from the file
BEV_FROM_FILE: dict[str, tuple[str, str, float]] = {
    **CHASSIS_FROM_FILE,
    "aux_w": ("body", "aux_power_w", 1.0), "j_mot": ("motor", "inertia_kg_m2", 1.0),
    "mot_tmax": ("motor", "max_torque_nm", 1.0), "mot_pmax": ("motor", "max_power_w", 1.0),
    "mot_max_spd": ("motor", "max_speed_rpm", RPM),
    "batt_cap_c": ("battery", "capacity_c", 1.0),
    "soc_init": ("charger", "soc_initial", 1.0),
    "soc_min": ("battery", "soc_min", 1.0), "soc_max": ("battery", "soc_max", 1.0),
    "regen_pmax": ("regen", "max_power_w", 1.0),
    "regen_fade_lo": ("regen", "fade_low_mps", 1.0),
    "regen_fade_hi": ("regen", "fade_high_mps", 1.0),
    "regen_share": ("regen", "driven_axle_share", 1.0),
    "drv_tau": ("driver", "response_time_s", 1.0), "drv_ki": ("driver", "ki_n_per_m", 1.0),
    "drv_int_lim": ("driver", "integrator_limit_n", 1.0),
    "drv_fmax": ("driver", "max_force_n", 1.0),
}


def bev_param_vector(veh: BatteryElectricVehicle, soc0: float | None = None) -> np.ndarray:
    """Scalar parameters of ``veh`` in SI, in the order of ``BEV_PARAMS`` (``soc0``: the
    initial SOC [-], default the vehicle's ``charger.soc_initial``)."""
    val = {name: getattr(getattr(veh, blk), key) * f
           for name, (blk, key, f) in BEV_FROM_FILE.items()}
    if soc0 is not None and np.isfinite(soc0):
        val["soc_init"] = float(soc0)
    return np.array([float(val[k]) for k in BEV_PARAMS])


def bev_maps(veh: BatteryElectricVehicle) -> tuple[np.ndarray, ...]:
    """Motor loss map and battery tables in SI, in the order the kernel takes them."""
    m = veh.motor.arrays()
    b = veh.battery
    arr = [np.asarray(x, float) for x in (b.soc, b.ocv_v, b.resistance_discharge_ohm,
                                          b.resistance_charge_ohm, b.discharge_power_limit_w,
                                          b.charge_power_limit_w)]
    return (m["spd"], m["trq"], m["loss"], *arr)


def summarise_bev(veh: BatteryElectricVehicle, ys: np.ndarray, soc0: float) -> dict:
    """Summary dict from the accumulator vector of the battery-electric loop.

    Keys: every ``BEV_SUMMARY`` entry plus ``soc_initial``, ``soc_delta``,
    ``dc_energy_kwh`` (net battery terminal energy), ``ac_energy_kwh`` (DC / charger
    efficiency), ``regen_energy_kwh`` (DC energy into the battery), ``dc_wh_per_mile``,
    ``ac_wh_per_mile``, ``ac_kwh_per_100mi``, ``ac_kwh_per_100km``, ``dc_kwh_per_100km``,
    ``mpge`` (AC basis, 33.705 kWh per gallon), ``trace_n_miss`` (int),
    ``energy_balance_residual_j`` and ``energy_balance_rel`` (chemical energy against the
    battery loss, motor loss, accessories, reduction loss, brakes, road load and the kinetic
    energy change).
    """
    s: dict[str, Any] = {k: float(v) for k, v in zip(BEV_SUMMARY, ys)}
    dist = s["distance_m"]
    dc = s["ess_dc_energy_j"]
    ac = ac_energy_j(dc, veh.charger.efficiency)
    sinks = (s["ess_loss_j"] + s["mot_loss_j"] + s["aux_energy_j"] + s["fd_loss_j"]
             + s["brake_energy_j"] + s["road_energy_j"] + s["ke_end_j"] - s["ke_start_j"])
    sources = s["ess_chem_energy_j"] + s["unmet_energy_j"]
    scale = max(abs(s["ess_chem_energy_j"]), s["road_energy_j"], 1.0)
    soc_initial = float(soc0) if np.isfinite(soc0) else veh.charger.soc_initial
    s.update({
        "architecture": "battery_electric",
        "soc_initial": soc_initial,
        "soc_delta": s["soc_final"] - soc_initial,
        "dc_energy_kwh": dc / 3.6e6,
        "ac_energy_kwh": ac / 3.6e6,
        "regen_energy_kwh": s["ess_dc_charge_j"] / 3.6e6,
        "charger_efficiency": veh.charger.efficiency,
        "dc_wh_per_mile": wh_per_mile(dc, dist),
        "ac_wh_per_mile": wh_per_mile(ac, dist),
        "ac_kwh_per_100mi": kwh_per_100mi(ac, dist),
        "ac_kwh_per_100km": kwh_per_100km(ac, dist),
        "dc_kwh_per_100km": kwh_per_100km(dc, dist),
        "mpge": mpge(ac, dist),
        "trace_n_miss": round(s["trace_n_miss"]),
        "energy_balance_residual_j": sources - sinks,
        "energy_balance_rel": (sources - sinks) / scale,
    })
    return s
