"""Several tests validated together (``vehval validate``): the tolerance ladder, the
normalised error of the fuel with U_model per cycle, and the model error against the
test-to-test variability of repeated cycles."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

from vehval import progress
from vehval.errors import ConfigError
from vehval.workflow.run import TestRun, ValidationOutcome

if TYPE_CHECKING:
    from vehval.validate.ladder import LadderResult

@dataclass
class SuiteOutcome:
    """Several tests validated together: ladder, repeatability and the documents.

    Attributes
    ----------
    runs, validations : list
        The runs and their validation outcomes, in the same order.
    ladder : vehval.validate.ladder.Ladder
        Pass/fail of every test against the tolerances.
    payload : dict
        ``validation.json``: report tables, figures and notes of every test.
    metrics : dict
        ``metrics.json``: per-test errors, ladder and test-to-test variability.
    """

    runs: list[TestRun]
    validations: list[ValidationOutcome]
    ladder: LadderResult
    payload: dict
    metrics: dict


def model_uncertainty_by_cycle(veh: Any, cycles: Sequence[str], method: str = "linear",
                               draws: int = 200) -> tuple[dict[str, float | None], list[str]]:
    """Relative U_model (k = 2) of the fuel of each cycle (:mod:`vehval.sim.model_uncertainty`,
    the vehicle as filed on the named cycle, dt 1 s); None where the cycle cannot be run by
    name (a trace without a packaged cycle) or ``method`` is ``none``; and notes."""
    from vehval.errors import VehvalError
    from vehval.sim.model_uncertainty import check_method, figure_uncertainty

    if method != "none":
        check_method(method, draws)
    out: dict[str, float | None] = {}
    notes: list[str] = []
    for cyc in dict.fromkeys(cycles):
        if method == "none" or not cyc:
            out[cyc] = None
            continue
        try:
            fu = figure_uncertainty(veh, cyc, method=method, draws=draws)
        except VehvalError as exc:   # e.g. a trace named after no packaged cycle
            out[cyc] = None
            notes.append(f"model uncertainty on '{cyc}': {exc}; U_model = 0")
            continue
        out[cyc] = fu.u_rel
        notes += fu.notes
    return out, notes


def fuel_normalised_error(veh: Any, comp: Any, u_model_rel: float | None,
                          notes: Sequence[str] = ()) -> dict[str, Any]:
    """The verdict by the normalised error of one test's fuel mass, as ``vehval validate``
    gives it per test (:func:`vehval.validate.ladder.judge_fuel`).

    Parameters
    ----------
    veh : Vehicle
        The model (its calibration tests make a test in-sample; its architecture picks the
        packaged precision's family).
    comp : vehval.validate.compare.Comparison
        The test's comparison.
    u_model_rel : float or None
        Relative U_model (k = 2) of the fuel on the test's cycle
        (:func:`model_uncertainty_by_cycle`); None: U_model = 0, noted.
    notes : sequence of str
        Notes of the model uncertainty, appended to ``note``.

    Returns
    -------
    dict
        ``figure`` (``fuel_mass_kg``), ``en``, ``consistent``, ``uninformative``,
        ``u_model_kg``, ``u_meas_kg`` (k = 2) [kg], ``s_r`` [-], ``model_kg``, ``measured_kg``
        [kg], ``error_pct`` (signed, model / measured - 1) [%], ``u_model_rel`` [-],
        ``in_sample``, ``verdict`` (``consistent``, ``inconsistent``, ``no En``), ``note``.
    """
    import math

    from vehval.architectures import stages
    from vehval.calibration.provenance import calibration_tests
    from vehval.validate.ladder import ladder

    lad = ladder([comp], calibrated=calibration_tests(veh), u_model_rel={comp.test_id: u_model_rel},
                 family=stages(veh).family)
    e = lad.entries[0]
    model, meas = e.errors["fuel_sim_kg"], e.errors["fuel_test_kg"]
    err = (100.0 * (model / meas - 1.0) if math.isfinite(model) and math.isfinite(meas)
           and meas > 0 else None)
    return {"figure": "fuel_mass_kg", "en": e.en, "consistent": e.consistent,
            "uninformative": e.uninformative, "u_model_kg": e.u_model_kg,
            "u_meas_kg": e.u_meas_kg, "s_r": e.s_r, "model_kg": model, "measured_kg": meas,
            "error_pct": err, "u_model_rel": u_model_rel, "in_sample": e.in_sample,
            "verdict": e.verdict, "note": "; ".join(n for n in (e.en_note, *notes) if n)}


def validate_runs(runs: Sequence[TestRun], tolerances: Any, *, dt: float = 0.1,
                  window_s: float = 2.0, smooth_hz: float | None = None,
                  model_uncertainty: str = "none", draws: int = 200) -> SuiteOutcome:
    """Validate each run, rank them on the tolerance ladder and compare the model error with
    the test-to-test variability of repeated cycles.

    ``model_uncertainty`` (``linear``, ``monte_carlo`` or ``none``) gives U_model of each
    test's normalised error (:func:`model_uncertainty_by_cycle`)."""
    from vehval.calibration.provenance import calibration_tests
    from vehval.validate import error_vs_repeatability, ladder, variability

    if not runs:
        raise ConfigError("no test to validate")
    if model_uncertainty != "none":   # refused before any simulation
        from vehval.sim.model_uncertainty import check_method

        check_method(model_uncertainty, draws)
    veh = runs[0].vehicle
    if veh is None:
        raise ConfigError("validation needs a vehicle model: pass --vehicle or set 'vehicle:' "
                          "in the template")
    from vehval.architectures import stages

    if not stages(veh).validate_suite:   # one line, before any test is simulated
        raise ConfigError(f"vehicle '{veh.name}' is '{stages(veh).name}': the tolerance "
                          "ladder ranks a power-split hybrid's simulations, not written for "
                          "it; vehval.workflow.validate_each judges its tests one by one "
                          f"({stages(veh).hint})")
    progress.add(len(runs))
    vals = []
    for one in runs:
        vals.append(one.validate(dt=dt, window_s=window_s, smooth_hz=smooth_hz))
        progress.advance()
    comps = [v.validation.comparison for v in vals]
    u_cyc, u_notes = model_uncertainty_by_cycle(veh, [c.cycle for c in comps],
                                                model_uncertainty, draws)
    lad = ladder(comps, tolerances, calibrated=calibration_tests(veh),
                 u_model_rel={c.test_id: u_cyc.get(c.cycle) for c in comps},
                 family=stages(veh).family)
    payload: dict[str, Any] = {
        "title": "Validation", "intro": f"{veh.name} simulated on each test's own speed trace, "
        "initial SOC, mass and road load", "tables": [], "figures": [], "notes": []}
    for v in vals:
        p = v.payload()
        payload["tables"] += p["tables"]
        payload["figures"] += p["figures"]
        payload["notes"] += [f"{v.validation.comparison.test_id}: {n}" for n in p["notes"]]
    payload["tables"] += lad.tables() + [lad.en_table()]
    metrics: dict[str, Any] = {
        "vehicle": veh.name, "vehicle_file": veh.file, "dt_s": dt,
        "speed_smoothing_hz": smooth_hz, "tests": [v.validation.to_dict() for v in vals],
        "ladder": lad.to_dict(), "model_uncertainty": {
            "method": model_uncertainty, "u_rel_by_cycle": u_cyc, "notes": u_notes}}
    by_cycle: dict[str, list[int]] = {}
    for i, run in enumerate(runs):
        by_cycle.setdefault(run.validated.meta.cycle or "", []).append(i)
    reps = []
    for cyc, idx in by_cycle.items():
        if len(idx) < 2:
            continue
        var = variability([runs[i].validated for i in idx], vehicle=veh)
        payload["tables"] += var.tables()
        rows = []
        for i in idx:
            comp = vals[i].validation.comparison
            for r in error_vs_repeatability(comp, var):
                rows.append([comp.test_id, r["quantity"], r["error"], r["test_std"],
                             r["ratio"], r["verdict"]])
        payload["tables"].append({"title": f"Model error against test repeatability ({cyc})",
                                  "columns": ["test", "quantity", "error (SI)", "test std (SI)",
                                              "|error| / std", "verdict"], "rows": rows})
        reps.append(var.to_dict())
    metrics["variability"] = reps
    return SuiteOutcome(list(runs), vals, lad, payload, metrics)
