"""Fixed-loss audit: the losses of a hybrid that do not scale with the road load.

A power-split hybrid spends part of its fuel on losses that do not grow with the work the
wheels ask for: the accessories, fuel burnt to start and idle the engine, the kinetic energy
of a stopping engine, the engine dragged round unfuelled, the machines' no-load (spin and
inverter standby) losses and the battery's self-discharge. Their share decides how fuel
economy moves with the road load: a car with more fixed loss than the real one is right at
one weight and road load and wrong at another.

:func:`fixed_loss_audit` books each such item over one charge-balanced cycle (from the
recorded run and the vehicle's maps, with the vehicle file's source of the parameter that
sets it), and measures the split directly: the SOC-corrected fuel energy at the road load
(mass, A, B, C together) x 0.9, 1 and 1.1; the straight line through them gives the fuel
that would remain at zero road load (the load-independent part) and the elasticity
d ln(fuel) / d ln(road load).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.integrals import held_sum
from vehval.sim.batch import simulate_batch
from vehval.sim.simulate import simulate
from vehval.vehicle import Vehicle, load_vehicle
from vehval.vehicle.maps import bilinear

#: road-load scale factors of the load sweep [-]
LOAD_SCALES = (0.9, 1.0, 1.1)
_BODY = ("mass_kg", "road_load_a_n", "road_load_b_n_per_mps", "road_load_c_n_per_mps2")
MPG = "fuel_economy_soc_corrected_mpg"


def no_load_loss_w(veh: Vehicle, machine: str, speed_rad_s: np.ndarray) -> np.ndarray:
    """The machine's loss map at zero torque (spin + inverter standby) [W] at ``speed``."""
    m = getattr(veh, machine)
    spd = np.asarray(m.speed_rpm, float) * RPM
    trq = np.asarray(m.torque_nm, float)
    loss = np.asarray(m.loss_w, float)
    w = np.abs(np.asarray(speed_rad_s, float))
    return bilinear(spd, trq, loss, w, np.zeros_like(w))


def _src(veh: Vehicle, key: str, n: int = 160) -> str:
    text = veh.sources().get(key, "not in the vehicle file")
    return text if len(text) <= n else text[: n - 3] + "..."


def _items(veh: Vehicle, res) -> list[dict[str, Any]]:
    s, sig = res.summary, res.test.signals
    dt = float(s["dt_s"])
    w_eng = np.asarray(sig["eng_spd_out_simu"].values, float)
    t_eng = np.asarray(sig["eng_trq_out_simu"].values, float)
    fuel = np.asarray(sig["fuel_rate_simu"].values, float)
    motoring = (t_eng < 0) & (fuel <= 0)
    e_motoring = held_sum(-t_eng * w_eng, dt, motoring)
    rows: list[dict[str, Any]] = [
        {"key": "accessories", "energy_j": float(s["aux_energy_j"]),
         "what": "electrical accessory load x cycle time", "source": _src(veh, "body.aux_power_w")},
        {"key": "engine_start_idle_fuel", "energy_j": float(s.get("idle_fuel_energy_j", 0.0)),
         "what": "fuel burnt while the engine delivers no power (starts, idle)",
         "source": _src(veh, "engine.fuel_rate_g_per_s")},
        {"key": "engine_stop", "energy_j": float(s.get("lock_loss_j", 0.0)),
         "what": "kinetic energy of a stopping engine", "source": _src(veh, "engine.inertia_kg_m2")},
        {"key": "engine_motoring", "energy_j": e_motoring,
         "what": "engine spun unfuelled (friction and pumping)",
         "source": _src(veh, "engine.motoring_torque_nm")},
    ]
    for mach, sname in (("mg1", "gen_spd_out_simu"), ("mg2", "mot_spd_out_simu")):
        w = np.asarray(sig[sname].values, float)
        rows.append({"key": f"{mach}_no_load", "energy_j": held_sum(no_load_loss_w(veh, mach, w), dt),
                     "what": f"{mach.upper()} + inverter loss at zero torque over the cycle's "
                             "speeds (spin, standby)", "source": _src(veh, f"{mach}.loss_w")})
    rows.append({"key": "battery_self_discharge", "energy_j": 0.0,
                 "what": "battery self-discharge (not modelled)",
                 "source": "not modelled: a NiMH or Li-ion pack's self-discharge (of the order "
                           "of a per cent of its 1 kWh a day) is below 1 W"})
    fuel_j = float(s["fuel_energy_j"])
    for r in rows:
        r["share_of_fuel"] = float(r["energy_j"]) / fuel_j if fuel_j > 0 else float("nan")
    return rows


def fixed_loss_audit(vehicle: Vehicle | str, cycle: str, dt: float = 0.2,
                     workers: int = 1) -> dict[str, Any]:
    """Fixed losses of ``vehicle`` over ``cycle`` (charge balanced) and the load sweep.

    Returns
    -------
    dict
        ``vehicle``, ``cycle``, ``dt_s``, ``fuel_energy_j`` (SOC-corrected fuel energy of the
        base run [J]), ``mpg`` (SOC-corrected), ``items`` (list of {``key``, ``energy_j``,
        ``share_of_fuel``, ``what``, ``source``}), ``fixed_total_j``, and ``load_sweep``:
        {``scales``, ``fuel_energy_j`` (per scale), ``load_independent_fuel_j`` (the line
        through them at scale 0), ``load_independent_share``, ``elasticity`` (d ln fuel /
        d ln road load at scale 1)}.
    """
    veh = load_vehicle(vehicle)
    res = simulate(veh, cycle, dt=dt, charge_balance=True)
    s = res.summary
    soc0 = float(s["soc_initial"])
    items = _items(veh, res)
    rows = [{f"body.{k}": getattr(veh.body, k) * f for k in _BODY} for f in LOAD_SCALES]
    sweep = simulate_batch(veh, cycle, rows, dt=dt, workers=workers, soc_initial=soc0)
    # SOC-corrected fuel energy (the simulator's energy-balance correction, summary's fuel mass)
    lhv = veh.engine.fuel_lhv_j_per_kg
    fuel_j = [float(r["fuel_mass_soc_corrected_kg"]) * lhv for r in sweep]
    x = np.asarray(LOAD_SCALES, float)
    slope, icpt = np.polyfit(x, np.asarray(fuel_j), 1)
    f1 = float(slope + icpt)
    return {"vehicle": veh.name, "cycle": s["cycle"], "dt_s": dt,
            "fuel_energy_j": f1, "mpg": float(s[MPG]), "items": items,
            "fixed_total_j": float(sum(r["energy_j"] for r in items)),
            "load_sweep": {"scales": list(LOAD_SCALES), "fuel_energy_j": fuel_j,
                           "load_independent_fuel_j": float(icpt),
                           "load_independent_share": float(icpt) / f1,
                           "elasticity": float(slope) / f1}}
