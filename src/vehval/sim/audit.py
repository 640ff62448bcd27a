"""Energy audit of a simulation: where the fuel and battery energy went.

The compiled loop books every energy flow per step with mid-step speeds (see
:mod:`vehval.sim.kernel`); the audit groups these accumulators into the items an engineer
reads: engine, electric path (MG1, MG2, boost, battery), driveline, accessories, road
load and braking, and the kinetic-energy change. The sinks add up to the sources (fuel
energy + battery chemical energy drawn) to round-off; ``closure_rel`` reports the residual.

Indicators (not part of the closure): engine mean efficiency while delivering power,
start/idle fuel, tractive energy at the wheels, braking demand and its friction share,
and the engine power recirculated through MG1 (motoring) and MG2 (generating).
"""

from __future__ import annotations

from typing import Any

#: tolerance of the audit closure [-] (fraction of fuel + |battery| energy)
AUDIT_CLOSURE_TOL = 0.005

#: (key, label, summary accumulators summed) of the sinks, in reading order
SINKS = (
    ("engine_loss_j", "engine losses (fuel energy not turned into work)", ("eng_loss_j",)),
    ("mg1_loss_j", "MG1 + inverter losses", ("gen_loss_j",)),
    ("mg2_loss_j", "MG2 + inverter losses", ("mot_loss_j",)),
    ("boost_loss_j", "boost converter losses", ("boost_loss_j",)),
    ("battery_loss_j", "battery resistive losses", ("ess_loss_j",)),
    ("accessories_j", "electrical accessories", ("aux_energy_j",)),
    ("final_drive_loss_j", "final drive losses", ("fd_loss_j",)),
    ("road_load_j", "road load (coast-down A + Bv + Cv²)", ("road_energy_j",)),
    ("friction_brake_j", "friction brakes", ("brake_energy_j",)),
    ("engine_stop_j", "kinetic energy of a stopping engine", ("lock_loss_j",)),
    ("kinetic_change_j", "kinetic energy change", ("ke_end_j", "-ke_start_j")),
    ("unmet_j", "battery power beyond its limit (unmet)", ("-unmet_energy_j",)),
)


def _get(s: dict[str, Any], key: str) -> float:
    if key.startswith("-"):
        return -float(s.get(key[1:], 0.0))
    return float(s.get(key, 0.0))


def energy_audit(summary: dict[str, Any]) -> dict[str, Any]:
    """Energy audit [J] from a simulation summary (:func:`vehval.sim.simulate.summarise`).

    Returns
    -------
    dict
        ``sources`` (``fuel_energy_j``, ``battery_energy_j`` = chemical energy drawn, > 0
        when discharged), ``sinks`` (see :data:`SINKS`), ``closure_residual_j``,
        ``closure_rel`` and ``closes`` (|rel| <= 0.5 %), and ``indicators``:
        ``engine_output_j``, ``engine_efficiency_on`` (engine work / fuel while it delivers
        power), ``start_idle_fuel_j``, ``tractive_energy_j`` (positive powertrain work at
        the wheels), ``braking_demand_j`` (regenerated at the wheels + friction),
        ``friction_brake_share``, ``recirculated_j`` (MG1 motoring while the engine
        delivers power), ``recirculation_share`` (of the engine output) and
        ``recirculation_mg1_loss_j``.
    """
    s = summary
    fuel = float(s["fuel_energy_j"])
    batt = float(s["ess_chem_energy_j"])
    sinks = {key: sum(_get(s, k) for k in keys) for key, _label, keys in SINKS}
    total = sum(sinks.values())
    scale = max(fuel + abs(batt), 1.0)
    eng_out = float(s["eng_out_energy_j"])
    idle = float(s.get("idle_fuel_energy_j", 0.0))
    brake = float(s["brake_energy_j"])
    regen = float(s.get("regen_wheel_energy_j", 0.0))
    recirc = float(s.get("recirc_energy_j", 0.0))
    loaded_fuel = fuel - idle
    return {
        "sources": {"fuel_energy_j": fuel, "battery_energy_j": batt},
        "sinks": sinks,
        "closure_residual_j": fuel + batt - total,
        "closure_rel": (fuel + batt - total) / scale,
        "closes": abs(fuel + batt - total) <= AUDIT_CLOSURE_TOL * scale,
        "indicators": {
            "engine_output_j": eng_out,
            "engine_efficiency_on": eng_out / loaded_fuel if loaded_fuel > 0 else 0.0,
            "start_idle_fuel_j": idle,
            "tractive_energy_j": float(s.get("tractive_energy_j", 0.0)),
            "braking_demand_j": brake + regen,
            "friction_brake_share": brake / (brake + regen) if brake + regen > 0 else 0.0,
            "recirculated_j": recirc,
            "recirculation_share": recirc / eng_out if eng_out > 0 else 0.0,
            "recirculation_mg1_loss_j": float(s.get("gen_motoring_loss_j", 0.0)),
        },
    }


def audit_lines(audit: dict[str, Any]) -> list[str]:
    """The audit as aligned text lines (MJ and % of the sources)."""
    src = audit["sources"]
    total = src["fuel_energy_j"] + src["battery_energy_j"]
    pct = 100.0 / total if total > 0 else 0.0
    out = [f"{'fuel energy':52s} {src['fuel_energy_j'] / 1e6:9.3f} MJ",
           f"{'battery energy drawn (chemical, + = discharged)':52s} "
           f"{src['battery_energy_j'] / 1e6:9.3f} MJ",
           "went to:"]
    for key, label, _ in SINKS:
        v = audit["sinks"][key]
        out.append(f"  {label:50s} {v / 1e6:9.3f} MJ {v * pct:6.1f} %")
    out.append(f"{'closure residual':52s} {audit['closure_residual_j'] / 1e6:9.3f} MJ "
               f"({100 * audit['closure_rel']:.2e} %)")
    ind = audit["indicators"]
    out += ["indicators:",
            f"  {'engine output':50s} {ind['engine_output_j'] / 1e6:9.3f} MJ",
            f"  {'engine mean efficiency while delivering power':50s} "
            f"{100 * ind['engine_efficiency_on']:9.1f} %",
            f"  {'start/idle fuel':50s} {ind['start_idle_fuel_j'] / 1e6:9.3f} MJ",
            f"  {'tractive energy at the wheels':50s} {ind['tractive_energy_j'] / 1e6:9.3f} MJ",
            f"  {'braking demand at the wheels':50s} {ind['braking_demand_j'] / 1e6:9.3f} MJ",
            f"  {'friction share of braking':50s} {100 * ind['friction_brake_share']:9.1f} %",
            f"  {'recirculated through MG1 -> MG2':50s} {ind['recirculated_j'] / 1e6:9.3f} MJ",
            f"  {'recirculation share of engine output':50s} "
            f"{100 * ind['recirculation_share']:9.1f} %"]
    return out
