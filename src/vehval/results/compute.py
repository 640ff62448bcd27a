"""The results stage: per-phase, whole-test and regulatory results with their uncertainty.

:func:`compute_results` takes a test (after QA, or straight from import) and returns a
:class:`TestResults` whose :meth:`TestResults.to_dict` is ``results.json`` (contract in
docs/results.md). Data stay SI; display units are the report's business.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.fuels import Fuel, fuel_volume_m3, mpg_from_volume_per_distance, resolve_fuel
from vehval.qa.findings import Finding
from vehval.results.composites import Composite, composites_for, substitute_direction
from vehval.results.gate import headline
from vehval.results.phases import Phase
from vehval.results.steps import (
    SCOPE_TEST,
    ResultsModel,
    accuracies,
    conditions_of_test,
    declared_accuracy,
    drive_quality_by_scope,
    fuel_of_test,
    input_roles,
    integrate_scopes,
    plan_phases,
    propagate_results,
    select_inputs,
    soc_step,
)
from vehval.results.uncertainty import ChannelAccuracy, Parameter
from vehval.test import Test

__all__ = [
    "QUANTITIES",
    "RESULTS_VERSION",
    "TestResults",
    "compute_results",
    "results_from_template",
]

#: Version of the results.json contract.
RESULTS_VERSION = 1
#: Quantity key -> SI unit, for every phase and the whole test.
QUANTITIES: dict[str, str] = {
    "duration_s": "s", "distance_m": "m", "mean_speed_mps": "m/s", "max_speed_mps": "m/s",
    "fuel_mass_kg": "kg", "fuel_volume_m3": "m^3", "fuel_economy_mpg": "mile/US gal",
    "fuel_consumption_l_per_100km": "L/100 km", "fuel_energy_j": "J", "co2_kg": "kg",
    "co2_g_per_km": "g/km", "ess_energy_net_j": "J",
}
#: Composite quantity key -> unit.
COMPOSITE_QUANTITIES = {"fuel_economy_mpg": "mile/US gal",
                        "fuel_consumption_l_per_100km": "L/100 km",
                        "fuel_per_distance_kg_per_m": "kg/m", "co2_g_per_km": "g/km",
                        "fuel_energy_per_distance_j_per_m": "J/m"}


@dataclass
class TestResults:
    """Results of one test (the content of ``results.json``)."""

    test_id: str
    cycle: str
    fuel: Fuel | None
    phase_source: str
    phases: list[Phase]
    values: dict[str, dict[str, float | None]]
    uncertainty: dict[str, dict[str, dict]]
    composites: list[Composite]
    drive_quality: dict[str, dict | None]
    soc: dict[str, Any]
    accuracy: dict[str, ChannelAccuracy]
    parameters: list[Parameter]
    conditions: dict[str, Any]
    method: str
    draws: int | None = None
    findings: list[Finding] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: Role (speed, fuel, co2, ess, phase) -> the signals the figures were computed from.
    inputs: dict[str, list[str]] = field(default_factory=dict)
    #: Scope -> withheld entry (:func:`vehval.results.gate.apply_gate`).
    withheld: dict[str, dict] = field(default_factory=dict)
    forced: bool = False
    #: SAE J1634 figures of a battery-electric test (:mod:`vehval.results.j1634`), else None.
    j1634: dict[str, Any] | None = None

    def value(self, scope: str, quantity: str) -> float | None:
        """A result value [SI] of a scope (``test``, a phase name or a composite name)."""
        return self.values.get(scope, {}).get(quantity)

    def expanded(self, scope: str, quantity: str) -> float | None:
        """Its expanded uncertainty U (k = 2), same unit, or None."""
        u = self.uncertainty.get(scope, {}).get(quantity)
        return None if u is None else u["U"]

    def _block(self, scope: str) -> dict:
        return {"values": self.values.get(scope, {}),
                "uncertainty": self.uncertainty.get(scope, {}),
                "drive_quality": self.drive_quality.get(scope),
                "withheld": self.withheld.get(scope)}

    def headline(self) -> dict[str, Any]:
        """The regulatory figure of the test's cycle (:func:`vehval.results.gate.headline`)."""
        return headline(self)

    def to_dict(self) -> dict[str, Any]:
        return _clean({
            "results_version": RESULTS_VERSION,
            "test": {"id": self.test_id, "cycle": self.cycle or None},
            "fuel": self.fuel.to_dict() if self.fuel else None,
            "conditions": self.conditions,
            "phase_source": self.phase_source,
            "phases": [dict(p.to_dict(), **self._block(p.name)) for p in self.phases],
            "test_total": self._block(SCOPE_TEST),
            "composites": [dict(c.to_dict(), values=self.values.get(c.name, {}),
                                uncertainty=self.uncertainty.get(c.name, {}),
                                withheld=self.withheld.get(c.name))
                           for c in self.composites],
            "headline": self.headline(),
            "withheld_count": len(self.withheld),
            "forced": self.forced,
            "inputs": {k: list(v) for k, v in self.inputs.items()},
            "soc_correction": self.soc,
            "uncertainty": {"method": self.method, "k": 2, "draws": self.draws,
                            "accuracy": {k: a.to_dict() for k, a in self.accuracy.items()},
                            "parameters": [{"name": p.name, "limit": p.limit, "kind": p.kind,
                                            "assumed": p.assumed} for p in self.parameters]},
            "units": {**QUANTITIES, **COMPOSITE_QUANTITIES},
            "findings": [f.to_dict() for f in self.findings],
            "notes": list(self.notes),
            **({"j1634": self.j1634} if self.j1634 is not None else {}),
        })


def _clean(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, (float, np.floating)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


def compute_results(test: Test, *, fuel: Any = None, accuracy: dict[str, Any] | None = None,
                    phase_channel: str | None = None, selected: dict[str, str] | None = None,
                    method: str = "first_order", draws: int = 1000, seed: int = 0,
                    hot_start_bag1: dict[str, float] | None = None,
                    soc_factor: float | None = None) -> TestResults:
    """Results of a test per phase, for the whole test and as regulatory composites.

    Parameters
    ----------
    test : Test
        Imported (and preferably QA-validated) test, SI signals.
    fuel : str, dict, FuelSpec, Fuel or ResolvedFuel, optional
        The test fuel; default the fuel :func:`vehval.fuels.resolve_fuel` finds for the test
        (the template ``fuel:`` kept at import, else the constants
        ``fuel_density_kg_per_m3`` / ``fuel_lhv_j_per_kg``). Without one, no volume, energy
        or carbon-based result is given and a mass-flow fuel channel gets a warning finding.
    accuracy : dict, optional
        Signal name -> ``AccuracySpec`` (template ``accuracy:``).
    phase_channel : str, optional
        Signal numbering the phases (default ``test_phase_test`` when present).
    selected : dict, optional
        Base name -> measured signal QA's selection kept; when given, only those measured
        signals are used. Every signal is chosen by :meth:`vehval.test.Test.best`.
    method : {'first_order', 'monte_carlo'}
        Uncertainty propagation.
    draws, seed : int
        Monte Carlo draws and seed.
    hot_start_bag1 : dict, optional
        ``fuel_mass_kg`` [kg], ``distance_m`` [m] (and ``co2_kg``) of a hot-start UDDS
        bag 1, standing in for the FTP bag 3 of a cold-start UDDS.
    soc_factor : float, optional
        Charge-balance factor [J fuel per J battery] for the SAE J1711 correction.

    Returns
    -------
    TestResults

    Notes
    -----
    The stage is the chain of named steps of :mod:`vehval.results.steps`: fuel, inputs,
    phases, conditions, accuracies, scope integrals, the results model and its propagation,
    drive quality and the SOC correction.
    """
    findings: list[Finding] = []
    notes: list[str] = []
    fuel_obj = fuel_of_test(test, fuel, notes)
    accuracy = declared_accuracy(test, accuracy, findings)
    inputs = select_inputs(test, selected, fuel_obj, findings)
    plan = plan_phases(test, inputs.speed, phase_channel, findings)
    roles = input_roles(test, inputs, plan, phase_channel)
    cond = conditions_of_test(test, inputs.kept)
    acc = accuracies(inputs, accuracy, fuel_obj)
    cold = None if cond["start"] is None else cond["start"] == "cold"
    composites = composites_for(plan.match.cycle if plan.match else None, plan.phases,
                                cold_start=cold, hot_bag1=hot_start_bag1 is not None,
                                match=plan.match, speed=inputs.speed, fuel=inputs.fuel,
                                conditions=cond, notes=notes)
    model = ResultsModel(inputs, integrate_scopes(inputs, plan), fuel_obj, plan.scopes,
                         composites, hot_start_bag1)
    res = propagate_results(model, acc.parameters, method=method, draws=draws, seed=seed,
                            notes=notes)
    notes.extend(substitute_direction(composites, res.values, hot_start_bag1,
                                      lambda fpd: _economy(fuel_obj, fpd)))
    dq = drive_quality_by_scope(test, inputs.speed, plan, findings, notes)
    soc = soc_step(res.values, plan, composites, inputs, soc_factor, findings)
    return TestResults(test_id=test.meta.test_id, cycle=test.meta.cycle, fuel=fuel_obj,
                       phase_source=plan.source, phases=plan.phases, values=res.values,
                       uncertainty=res.uncertainty, composites=composites, drive_quality=dq,
                       soc=soc, accuracy=acc.accuracy, parameters=acc.parameters,
                       conditions=cond, method=res.method,
                       draws=draws if res.method == "monte_carlo" else None,
                       findings=findings, notes=notes, inputs=roles)


def _economy(fuel: Fuel | None, fuel_per_distance: float) -> float | None:
    """Fuel per distance [kg/m] -> fuel economy [mpg] with the nominal fuel density (None
    without one)."""
    if fuel is None or not fuel.density_kg_per_m3:
        return None
    return float(mpg_from_volume_per_distance(fuel_volume_m3(fuel_per_distance,
                                                             fuel.density_kg_per_m3)))


def results_from_template(test: Test, template: Any, vehicle: Any = None,
                          **kw: Any) -> TestResults:
    """:func:`compute_results` with the template's fuel (:func:`vehval.fuels.resolve_fuel`),
    ``accuracy`` and ``phase_channel``; the SAE J1634 figures of a battery-electric test
    (the template's or ``vehicle``'s architecture) with the charger efficiency of ``vehicle``
    (the command line's ``--vehicle``), else of the template's ``vehicle:``, and the measured
    wall energy ``constants.ac_recharge_energy_j`` when the template states one."""
    fuel = resolve_fuel(template=template, test=test)
    kw.setdefault("soc_factor", getattr(template.constants, "soc_correction_fuel_j_per_battery_j",
                                        None))
    res = compute_results(test, fuel=fuel, accuracy=template.accuracy,
                          phase_channel=template.phase_channel, **kw)
    arch = getattr(template, "architecture", None) or getattr(vehicle, "architecture", None)
    if arch == "battery_electric":
        attach_j1634(res, _charger_efficiency(template, vehicle),
                     getattr(template.constants, "ac_recharge_energy_j", None))
    return res


def attach_j1634(res: TestResults, charger_efficiency: float | None,
                 ac_recharge_energy_j: float | None) -> TestResults:
    """``res`` with the SAE J1634 figures of a battery-electric test (charger efficiency
    [-], None: assumed; measured wall energy [J], None: from the DC energy)."""
    from vehval.results.j1634 import j1634_results

    res.j1634 = j1634_results(res, charger_efficiency, ac_recharge_energy_j)
    return res


def results_of_validated(test: Test, vehicle: Any = None, **kw: Any) -> TestResults:
    """:func:`compute_results` of a validated test read back (no template: its metadata
    holds the fuel and constants), with the SAE J1634 figures when ``vehicle`` is
    battery-electric (its charger, the test's measured wall energy constant)."""
    res = compute_results(test, **kw)
    if getattr(vehicle, "architecture", None) == "battery_electric":
        attach_j1634(res, _charger_efficiency(None, vehicle),
                     (test.meta.constants or {}).get("ac_recharge_energy_j"))
    return res


def _charger_efficiency(template: Any, vehicle: Any = None) -> float | None:
    """The charger efficiency of ``vehicle`` (loaded), else of the template's vehicle file,
    if it is battery-electric."""
    veh = vehicle
    if veh is None:
        if not getattr(template, "vehicle", None):
            return None
        from vehval.vehicle import load_vehicle
        veh = load_vehicle(template.vehicle)
    charger = getattr(veh, "charger", None)
    return None if charger is None else float(charger.efficiency)
