"""`vehval epa vehicle` as one stage: a conventional vehicle from its EPA Test Car List rows,
its fuel model calibrated on dyno tests with speed and fuel only (:mod:`vehval.epa.specs_fit`),
held-out tests predicted, and the result document (the command's ``--json``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from vehval.epa.specs_fit import DynoRun


def uncalibrated_note(specs: Any = None) -> str:
    """What a vehicle built without calibration tests is: the generic technology
    coefficients of its engine and gearbox (:mod:`vehval.epa.technology`)."""
    from vehval.epa import technology as tech
    from vehval.epa.specs import INDICATED_EFFICIENCY

    head = "fuel model not calibrated (no --calibrate test)"
    if specs is None:
        return f"{head}: the generic technology coefficients"
    c = tech.load_coefficients()
    e = tech.engine_values(c, specs.engine_technology, specs.rated_power_w,
                           specs.displacement_l, None, None, INDICATED_EFFICIENCY)
    engine = tech.ENGINE_TECHNOLOGY_TEXT.get(specs.engine_technology, specs.engine_technology)
    box = specs.family.replace("_", " ")
    return (f"{head}: the generic technology coefficients ({c.where}) of "
            f"{'an' if engine[:1] in 'aeiou' else 'a'} {engine} engine and "
            f"{'an' if box[:1] in 'aeiou' else 'a'} {box} gearbox: indicated efficiency "
            f"{100 * e['indicated_efficiency'][0]:.0f} %, friction scale "
            f"{e['friction_scale'][0]:.2g} x Heywood, idle fuel {e['idle_factor'][0]:.2g} x "
            f"the map, part-load pumping {e['pumping_bar'][0]:.2g} bar")


@dataclass
class DynoTest:
    """One dyno test of the stage: its run, whether the fuel model is fitted on it, and the
    unit hints QA gave on its speed and fuel signals (``signal``, ``message``, ``fix``)."""

    run: DynoRun
    in_sample: bool
    unit_hints: list[dict[str, str]] = field(default_factory=list)


@dataclass
class DynoVehicle:
    """The stage's outcome: specification, fit (None without calibration tests), vehicle,
    fuel errors of the held-out tests [-] by test, the split rows, the tests."""

    specs: Any
    fit: Any
    vehicle: Any
    predictions: dict[str, float]
    splits: list[dict[str, Any]]
    tests: list[DynoTest]

    def test_rows(self) -> list[dict[str, Any]]:
        """One row per dyno test: fuel [kg], distance [m], cold start, notes, hints, error."""
        from vehval.epa.specs_fit import cold_note

        return [{"test": t.run.test_id, "in_sample": t.in_sample,
                 "fuel_measured_kg": t.run.fuel_kg, "distance_m": t.run.distance_m,
                 "cold_start": t.run.cold, "note": cold_note(t.run),
                 "fuel_note": t.run.fuel_note, "unit_hints": t.unit_hints,
                 "error": (self.fit.errors.get(t.run.test_id) if t.in_sample and self.fit
                           else self.predictions.get(t.run.test_id))} for t in self.tests]

    def to_dict(self) -> dict[str, Any]:
        """The document of `vehval epa vehicle --json`."""
        return {"vehicle": self.vehicle.name, "specs": self.specs.to_dict(),
                "calibration": self.fit.to_dict() if self.fit else None,
                "tests": self.test_rows(), "splits": self.splits}


def dyno_vehicle(specs: Any, tests: Sequence[DynoTest], dt: float,
                 splits: int = 0) -> DynoVehicle:
    """Build the vehicle of ``specs`` (:func:`vehval.epa.specs.specs_from_tests` of one test
    vehicle and configuration), fit its
    fuel model on the in-sample ``tests``, predict the others at step ``dt`` [s], and with
    ``splits`` > 0 fit on every ``splits`` of all the tests and predict the rest."""
    from vehval.epa.specs import vehicle_from_specs
    from vehval.epa.specs_fit import all_splits, calibrate_specs, predict_runs

    cal = [t.run for t in tests if t.in_sample]
    held = [t.run for t in tests if not t.in_sample]
    fit = calibrate_specs(specs, cal, dt) if cal else None
    veh = fit.vehicle() if fit is not None else vehicle_from_specs(
        specs, note=f"; {uncalibrated_note(specs)}")
    pred = predict_runs(fit.model() if fit else veh, held, dt) if held else {}
    split_rows = all_splits(specs, [t.run for t in tests], splits, dt) if splits else []
    return DynoVehicle(specs, fit, veh, pred, split_rows, list(tests))
