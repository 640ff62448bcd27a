"""The energy flow of a test, drawn from its architecture's own energy audit.

A conventional car's audit follows the energy from the fuel to the road, with only what
the test measured: fuel energy (fuel flow x LHV); engine output when the engine torque is
measured or calculated; the tractive work at the wheels (tractive force x speed, its
positive part) and the work the wheels absorb while braking (its negative part). Then

* fuel = engine losses + engine output (engine output known), or fuel = wheels +
  engine, driveline and accessory losses, not separated (no engine torque);
* engine output = driveline losses and accessories (the balance) + wheels;
* wheels = road load as the dyno applied it + brakes and engine braking + kinetic energy
  change, where road load = traction - braking - kinetic change (the balance at the wheels,
  so the measured force closes it; the coast-down coefficients give the cross-check
  ``road_load_coefficients``).

Every leaf of the diagram is a sink; the sinks add up to the fuel energy by construction
(``closure_rel`` reports clipping). The hybrid's power-split diagram stays in
:func:`vehval.report.plots.sankey_figure`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.display import as_unit
from vehval.figures.engineering import sankey_figure
from vehval.report.plots import PlotSkipped, energy_flows, pick
from vehval.test import Test
from vehval.test import is_hybrid as test_is_hybrid

__all__ = ["conventional_audit", "conventional_sankey", "is_hybrid"]
#: Label of the cross-check row of the audit table.
ROAD_LOAD_CROSS_CHECK = ("road load from the target (coast-down) coefficients (cross-check: it "
                         "includes the car's own tyre and driveline losses on the rollers, "
                         "which the dyno does not apply and the measured force does not see; "
                         "they are in the losses above)")
#: Sinks of the conventional audit: key -> label, in reading order.
SINKS = {
    "engine_loss_j": "Engine losses",
    "powertrain_loss_j": "Engine, driveline and accessory losses (not separated: no engine torque)",
    "driveline_accessories_j": "Driveline losses and accessories",
    "road_load_j": "Road load",
    "brakes_j": "Brakes and engine braking",
    "kinetic_change_j": "Kinetic energy change",
}


def is_hybrid(test: Test, vehicle: Any = None) -> bool:
    """True for a hybrid: the vehicle file's architecture, else a hybrid component signal
    (measured or calculated; :func:`vehval.test.is_hybrid`)."""
    return test_is_hybrid(test, vehicle, measured_only=False)


def _mass_kg(test: Test) -> float | None:
    m = (test.meta.constants or {}).get("test_mass_kg")
    return float(m) if m else None


def conventional_audit(test: Test) -> dict[str, Any]:
    """Energy audit [J] of a conventional car's test (see the module docstring).

    Returns
    -------
    dict
        ``fuel_j``, ``engine_output_j`` (None when not measured), ``traction_j``,
        ``sinks`` (keys of :data:`SINKS` present), ``closure_rel`` (fuel - sinks) / fuel,
        ``road_load_coefficients_j`` (A + Bv + Cv^2 x speed, or None).

    Raises
    ------
    PlotSkipped
        Without fuel energy or tractive work.
    """
    flows = energy_flows(test)
    fuel, eng = flows.get("fuel"), flows.get("engine")
    trac, brake = flows.get("wheel_out"), flows.get("braking")
    if not fuel:
        raise PlotSkipped("no fuel energy (fuel flow and a declared fuel)")
    if trac is None or brake is None:
        raise PlotSkipped("no tractive force or wheel power: the wheels' share is unknown")
    ke = 0.0
    v, m = pick(test, "veh_spd", ("test", "calc")), _mass_kg(test)
    if v is not None and m is not None:
        ok = np.isfinite(v.values)
        if ok.sum() >= 2:
            v0, v1 = v.values[ok][0], v.values[ok][-1]
            ke = 0.5 * m * (v1 * v1 - v0 * v0)
    sinks: dict[str, float] = {}
    if eng is not None and eng > 0:
        sinks["engine_loss_j"] = max(fuel - eng, 0.0)
        sinks["driveline_accessories_j"] = max(eng - trac, 0.0)
    else:
        eng = None
        sinks["powertrain_loss_j"] = max(fuel - trac, 0.0)
    sinks["road_load_j"] = max(trac - brake - ke, 0.0)
    sinks["brakes_j"] = brake
    if ke > 0:
        sinks["kinetic_change_j"] = ke
    return {"fuel_j": fuel, "engine_output_j": eng, "traction_j": trac, "sinks": sinks,
            "closure_rel": (fuel - sum(sinks.values())) / fuel,
            "road_load_coefficients_j": flows.get("road_load")}


def conventional_sankey(audit: dict[str, Any],
                        title: str = "Energy flow over the test") -> Any:
    """Sankey diagram [MJ] of :func:`conventional_audit`: fuel -> engine -> wheels -> road."""
    s = audit["sinks"]
    nodes = ["Fuel", "Engine output", "Wheels (traction)", *[SINKS[k] for k in s]]
    links: list[tuple[int, int, float]] = []

    def link(a: str, b: str, v: float | None) -> None:
        if v is not None and v > 0:
            links.append((nodes.index(a), nodes.index(b), float(as_unit(v, "MJ"))))

    trac = audit["traction_j"]
    if audit["engine_output_j"] is not None:
        link("Fuel", SINKS["engine_loss_j"], s["engine_loss_j"])
        link("Fuel", "Engine output", audit["engine_output_j"])
        link("Engine output", SINKS["driveline_accessories_j"], s["driveline_accessories_j"])
        link("Engine output", "Wheels (traction)", min(trac, audit["engine_output_j"]))
    else:
        link("Fuel", SINKS["powertrain_loss_j"], s["powertrain_loss_j"])
        link("Fuel", "Wheels (traction)", trac)
    for key in ("road_load_j", "brakes_j", "kinetic_change_j"):
        if key in s:
            link("Wheels (traction)", SINKS[key], s[key])
    colors = {"Fuel": "#e67700", "Engine output": "#d9480f", "Wheels (traction)": "#0b7285"}
    return sankey_figure(nodes, links, title=title,
                         colors=[colors.get(n, "#adb5bd") for n in nodes])


def audit_rows(audit: dict[str, Any]) -> list[list[Any]]:
    """Rows (item, energy [MJ], share of the fuel energy [%]) of the audit table."""
    fuel = audit["fuel_j"]
    rows: list[list[Any]] = [["fuel energy", as_unit(fuel, "MJ"), as_unit(1.0, "%")]]
    if audit["engine_output_j"] is not None:
        rows.append(["engine output", as_unit(audit["engine_output_j"], "MJ"),
                     as_unit(audit["engine_output_j"] / fuel, "%")])
    rows.append(["wheels (traction)", as_unit(audit["traction_j"], "MJ"),
                 as_unit(audit["traction_j"] / fuel, "%")])
    rows += [[SINKS[k].lower(), as_unit(v, "MJ"), as_unit(v / fuel, "%")] for k, v in audit["sinks"].items()]
    rc = audit.get("road_load_coefficients_j")
    if rc is not None:
        # the target coefficients hold the car's own tyre and driveline losses; a chassis
        # dyno applies only the rest (its set coefficients): the force measured at the rollers
        # closes the balance with that part, so on a real dyno this figure is the larger one
        rows.append([ROAD_LOAD_CROSS_CHECK, as_unit(rc, "MJ"), as_unit(rc / fuel, "%")])
    return rows
