"""Validate a vehicle model against one test: simulate on the test's conditions and compare.

``validate_test(test, vehicle)`` builds the test's conditions (measured speed trace,
measured initial SOC, template mass and road load), runs the forward-looking simulation
on them and compares test and simulation (:func:`vehval.validate.compare.compare`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from vehval.equations.engine_state import ENGINE_ON_RPM
from vehval.jsonsafe import clean
from vehval.sim.simulate import SimResult, simulate
from vehval.test import Test
from vehval.validate.compare import Comparison, compare, overlay_figures
from vehval.validate.conditions import (
    Conditions,
    simulation_conditions,
    vehicle_variant,
)
from vehval.validate.match import VehicleMatch, vehicle_match
from vehval.vehicle import Vehicle, load_vehicle

#: Whole-test figures of the results stage stated as ``measured`` in validation.json.
MEASURED_KEYS = ("distance_m", "fuel_mass_kg", "fuel_volume_m3", "fuel_economy_mpg",
                 "fuel_consumption_l_per_100km", "fuel_energy_j")


@dataclass
class Validation:
    """One test validated: its conditions, the simulation and the comparison.

    ``measured`` holds the results stage's whole-test figures (:data:`MEASURED_KEYS`, the
    figures every command states for the test); the comparison's ``totals_test`` reduce the
    measured signals on the simulation's grid, like the simulated ones, for the errors.
    """

    conditions: Conditions
    sim: SimResult
    comparison: Comparison
    overrides: dict[str, Any]
    match: VehicleMatch | None = None
    measured: dict[str, Any] | None = None

    def payload(self, figures: bool = True) -> dict[str, Any]:
        """The ``validation`` dict of the report: ``{tables, figures, notes}``."""
        c = self.comparison
        return {"tables": c.tables(), "figures": overlay_figures(c) if figures else [],
                "notes": self.conditions.notes + c.notes}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (``validation.json``)."""
        d = self.comparison.to_dict()
        d["conditions"] = self.conditions.to_dict()
        d["overrides"] = dict(self.overrides)
        d["vehicle"] = self.sim.vehicle.name
        d["vehicle_file"] = self.sim.vehicle.file
        if self.match is not None:
            d["vehicle_match"] = self.match.to_dict()
        d["dt_s"] = self.sim.dt
        if self.measured is not None:
            d["measured"] = dict(self.measured)
        d["sim_summary"] = {k: v for k, v in self.sim.summary.items()
                            if isinstance(v, (int, float, str, bool))}
        return clean(d)


def validate_test(test: Test, vehicle: Vehicle | str, *, dt: float = 0.1,
                  overrides: dict[str, Any] | None = None, window_s: float = 2.0,
                  use_constants: bool = True, on_speed_rpm: float = ENGINE_ON_RPM,
                  smooth_hz: float | None = None,
                  results: Any = None) -> Validation:
    """Simulate ``vehicle`` on the conditions of ``test`` and compare the two.

    Parameters
    ----------
    test : Test
        Measured (validated) test.
    vehicle : Vehicle or name/path
        The model.
    dt : float
        Simulation step [s].
    overrides : dict, optional
        Extra dotted parameter overrides (applied after the template's mass and road load).
    window_s : float
        Engine start/stop matching window [s].
    use_constants : bool
        Use the template's mass and road-load constants.
    on_speed_rpm : float
        Engine-on speed threshold [rpm] when the engine state comes from engine speed.
    smooth_hz : float, optional
        Zero-phase low-pass cut-off [Hz] of the measured speed given to the driver
        (:func:`vehval.validate.conditions.smooth_speed`); default None, the trace as measured.
        The comparison itself always uses the measured signals.
    results : vehval.results.TestResults, optional
        Results of the test (with the template's declared accuracies) whose whole-test
        uncertainties give the verdicts; default: computed here from the test with the
        class-default accuracies (flagged assumed in the verdict note).
    """
    veh = load_vehicle(vehicle)
    cond = simulation_conditions(test, veh, use_constants=use_constants, smooth_hz=smooth_hz)
    ov = dict(cond.overrides)
    ov.update(overrides or {})
    sim = simulate(vehicle_variant(veh, ov) if ov else veh, cond.cycle, dt=dt,
                   soc_initial=cond.soc_initial)
    if results is None:
        results = _results(test, cond)
    unc, basis = _relative_uncertainty(results)
    measured = None
    if results is not None:
        measured = {k: results.value("test", k) for k in MEASURED_KEYS}
        measured["fuel"] = results.fuel.name if results.fuel is not None else None
    comp = compare(test, sim.test, dt=dt, window_s=window_s, on_speed_rpm=on_speed_rpm,
                   fuel=cond.fuel, uncertainty_rel=unc,
                   uncertainty_basis=basis)
    match = vehicle_match(test, veh)
    if not match.matches:
        cond.notes.insert(0, f"warning: {match.message()}")
    return Validation(conditions=cond, sim=sim, comparison=comp, overrides=ov, match=match,
                      measured=measured)


def _results(test: Test, cond: Conditions) -> Any:
    """The results stage of the test with the comparison's fuel (None when it fails)."""
    from vehval.results import compute_results

    try:
        return compute_results(test, fuel=cond.fuel)
    except Exception:  # noqa: BLE001 - no verdict rather than no validation
        return None


def _relative_uncertainty(results: Any) -> tuple[dict[str, float], str]:
    """Relative standard uncertainty of the whole-test quantities, and its basis."""
    from vehval.validate.compare import VERDICT_KEYS

    if results is None:
        return {}, ""
    out = {}
    for key in VERDICT_KEYS:
        v, u = results.value("test", key), results.uncertainty.get("test", {}).get(key)
        if v and u:
            out[key] = u["u"] / abs(v)
    assumed = sorted(k for k, a in results.accuracy.items() if a.assumed)
    basis = ("measurement uncertainty from the results stage (" + results.method.replace("_", " ")
             + ")" + (f"; class-default accuracies assumed for {', '.join(assumed)}" if assumed else ""))
    return out, basis
