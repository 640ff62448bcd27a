"""The validation of a conventional car on one test: its model driven over the test's
measured speed, fuel measured against predicted per test and phase (the comparison of
``vehval predict``), as the workflow's validate step gives it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass
class PredictionComparison:
    """One test predicted by a conventional model: ``row`` (:func:`predict_trace`'s row,
    arrays included) and the ``vehicle`` that ran."""

    row: dict[str, Any]
    vehicle: Any

    def to_dict(self) -> dict[str, Any]:
        """The row of ``vehval predict --json`` (without arrays, fuel economy added)."""
        from vehval.identify.predict import public_row

        return public_row(self.row, self.vehicle)

    def payload(self, figures: bool = True) -> dict[str, Any]:
        """The report's validation section: ``{tables, figures, notes}`` (fuel [g] measured
        and predicted per phase and for the whole test; no figures)."""
        r = self.row
        rows = [[p.get("results_name", f"phase {p['phase']}"), p["measured_g"],
                 p["predicted_g"], 100 * p["error_rel"]] for p in r["phases"]]
        rows.append(["whole test", r["fuel_measured_g"], r["fuel_predicted_g"],
                     100 * r["error_rel"]])
        table = {"title": f"Fuel measured and predicted ({r['test']})",
                 "columns": ["phase", "measured [g]", "predicted [g]", "error [%]"],
                 "rows": rows}
        notes = [f"{self.vehicle.name} driven over the measured speed of {r['test']}; A/C "
                 f"{'on' if r['ac_on'] else 'off'}: {r['ac_reason']}; {r['cold_reason']}"]
        return {"tables": [table], "figures": [], "notes": notes}


def predict_comparison(vehicle: Any, test: Any, overrides: dict | None = None,
                       ac: str = "auto") -> PredictionComparison:
    """Predict the imported ``test`` with the conventional ``vehicle`` (``overrides``:
    dotted parameter values), after checking the test is of the same car."""
    from vehval.identify.predict import check_same_car, predict_trace
    from vehval.identify.traces import trace_from_test
    from vehval.results import compute_results

    veh = vehicle.with_overrides(overrides) if overrides else vehicle
    trace = trace_from_test(test, 0.1, veh)
    trace.results = compute_results(test)
    check_same_car(veh, trace)
    return PredictionComparison(predict_trace(veh, trace, ac=ac), veh)
