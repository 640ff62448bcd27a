"""The validation of a conventional car on one test: its model driven over the test's
measured speed, fuel measured against predicted per test and phase (the comparison of
``vehval predict``, its normalised errors En included: :func:`vehval.identify.verdicts.judge_row`),
as the workflow's validate step gives it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass
class PredictionComparison:
    """One test predicted by a conventional model: ``row`` (:func:`predict_trace`'s row,
    arrays included, judged by :func:`vehval.identify.verdicts.judge_row`), the ``vehicle``
    that ran, and ``s_r`` and ``note`` of the judgement (the repeatability used, the cycle
    whose precision was borrowed)."""

    row: dict[str, Any]
    vehicle: Any
    s_r: float | None = None
    note: str = ""

    def normalised_error(self) -> dict[str, Any]:
        """The verdict by the normalised error of the test's fuel mass, in the keys of
        :func:`vehval.workflow.fuel_normalised_error` (the batch's ``normalised_error``, the
        catalog's ``fuel_en`` ...): the En ``vehval predict`` states for the test, in kg."""
        r = self.row
        en = r.get("en")

        def kg(g: float | None) -> float | None:
            return None if g is None else g / 1e3

        err = r.get("error_rel")
        notes = [n for n in (self.note, "a vehicle without identification uncertainty: "
                             "U_model = 0" if r.get("pi95_rel") is None else "") if n]
        return {"figure": "fuel_mass_kg", "en": en, "consistent": r.get("consistent"),
                "uninformative": r.get("uninformative"), "u_model_kg": kg(r.get("u_model_g")),
                "u_meas_kg": kg(r.get("u_meas_g")), "s_r": r.get("s_r"),
                "model_kg": kg(r.get("fuel_predicted_g")),
                "measured_kg": kg(r.get("fuel_measured_g")),
                "error_pct": None if err is None or err != err else 100.0 * err,
                "u_model_rel": r.get("pi95_rel"), "in_sample": bool(r.get("in_sample")),
                "outside_identification": bool(r.get("outside_identification")),
                "verdict": ("no En" if en is None else
                            "consistent" if r.get("consistent") else "inconsistent"),
                "note": "; ".join(notes)}

    def verdict(self) -> dict[str, Any]:
        """The test's verdict: the normalised error of its fuel mass (as ``vehval
        predict`` states it), with the fuel in ``text``."""
        from vehval.validate.ladder import in_set_verdict

        r, ne = self.row, self.normalised_error()
        return {"figure": "fuel_mass_g", "en": ne["en"], "consistent": ne["consistent"],
                "model": r["fuel_predicted_g"], "measured": r["fuel_measured_g"],
                "u_model": r.get("u_model_g"), "u_meas": r.get("u_meas_g"),
                "s_r": ne.get("s_r") or 0.0, "in_set": in_set_verdict(r),
                "text": f"fuel {r['fuel_predicted_g']:.1f} g against {r['fuel_measured_g']:.1f} g"}

    def to_dict(self) -> dict[str, Any]:
        """The row of ``vehval predict --json`` (without arrays, fuel economy added)."""
        from vehval.identify.predict import public_row

        return public_row(self.row, self.vehicle)

    def payload(self, figures: bool = True) -> dict[str, Any]:
        """The report's validation section: ``{tables, figures, notes}`` (fuel [g] measured
        and predicted per phase and for the whole test, each with its normalised error En
        and verdict as ``vehval predict`` states them; no figures)."""
        r = self.row

        def judged(p: dict) -> list:
            en = p.get("en")
            return [en, "no En" if en is None else
                    "consistent" if p.get("consistent") else "inconsistent"]
        rows = [[p.get("results_name", f"phase {p['phase']}"), p["measured_g"],
                 p["predicted_g"], 100 * p["error_rel"], *judged(p)] for p in r["phases"]]
        rows.append(["whole test", r["fuel_measured_g"], r["fuel_predicted_g"],
                     100 * r["error_rel"], *judged(r)])
        table = {"title": f"Fuel measured and predicted ({r['test']})",
                 "columns": ["phase", "measured [g]", "predicted [g]", "error [%]", "En",
                             "verdict (|En| <= 1)"],
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
    from vehval.identify.verdicts import judge_row
    from vehval.results import compute_results

    veh = vehicle.with_overrides(overrides) if overrides else vehicle
    trace = trace_from_test(test, 0.1, veh)
    trace.results = compute_results(test)
    check_same_car(veh, trace)
    row = predict_trace(veh, trace, ac=ac)
    _, s_r, note = judge_row(row)   # the En of vehval predict, per test and phase
    return PredictionComparison(row, veh, s_r, note)
