"""Normalised error of every EPA figure and the set verdict (``vehval epa validate``).

Each predicted-vs-listed figure (:class:`vehval.epa.validation.Comparison`) gets
``En = (predicted - measured) / sqrt(U_model^2 + U_meas^2)``
(:func:`vehval.uncertainty.normalised_error`), in mpg, k = 2:

* **U_model**: the vehicle file's parameter ranges propagated to the SOC-corrected fuel
  economy of the procedure's cycle (:func:`vehval.sim.model_uncertainty.figure_uncertainty`:
  FTP-75 -> UDDS, HWFET, US06; the vehicle as filed, dt 1 s), as a share of the figure,
  applied to every figure of that procedure (whole test and bags). 0 when the vehicle
  declares no ranges or the method is ``none`` (stated in the notes).
* **U_meas**: a list row carries no uncertainty of its own; its spread is that of a repeated
  test (:func:`vehval.uncertainty.measurement_uncertainty`), from the packaged defaults of
  the procedure and powertrain family (:func:`vehval.uncertainty.defaults.precision_default`;
  ``hybrid`` when the vehicle has a battery, else ``conventional``; a bag takes its
  procedure's whole-test figure). **Source rule**: the vehicle file was calibrated on rows of
  the same test vehicle ID and the same lab (originator) -> same source, ``s_r``; calibrated
  on that test vehicle in the other lab -> ``s_R`` (one configuration, EPA against the
  manufacturer); otherwise (another car, a trim, or a file not calibrated on the list) ->
  ``s_R_vehicle`` (vehicle level). A figure the defaults cannot give falls back to the
  other s_R, then to s_r (said in ``precision.basis``).

**Set verdict** (:func:`vehval.uncertainty.set_verdict`) over the held-out judged figures,
one per test so that bags do not count a test twice: its whole-test figure when judged,
else its hot UDDS (bags 3 + 4). The set's s_r is the root mean square of the figures'
s_r; it counts as from a different source when any figure does, with the root mean square
of their s_R. Fewer than 3 such figures: no verdict, and the reason. When some tests are
in-sample (the vehicle file was calibrated on them) a second verdict, ``set_verdict_all``,
is over every judged test, in-sample included, with the same rule (one figure per test): the
whole selection's agreement, which is not a prediction.
"""

from __future__ import annotations

import math
from typing import Any

from vehval.epa.reader import EpaTest
from vehval.errors import ConfigError
from vehval.sim.model_uncertainty import FigureUncertainty, check_method, figure_uncertainty
from vehval.sim.sensitivity import PROCEDURE_CYCLE
from vehval.sim.simulate import architecture
from vehval.uncertainty import InsufficientDataError, normalised_error, set_verdict
from vehval.uncertainty.defaults import precision_default
from vehval.uncertainty.verdict import measurement_uncertainty
from vehval.vehicle import Vehicle

#: Model-uncertainty methods of ``vehval epa validate --model-uncertainty``.
MODEL_U_METHODS = ("linear", "monte_carlo", "none")


def _sources(calibrated: dict[str, list[str]], every: list[EpaTest]) -> tuple[set, set]:
    """(vehicle ID, originator) pairs and vehicle IDs of the calibration tests in the lists."""
    cal = [t for t in every if t.label in calibrated or (t.test_number and
                                                         t.test_number in calibrated)]
    return {(t.vehicle_id, t.originator) for t in cal}, {t.vehicle_id for t in cal}


def measurement_precision(procedure: str, family: str, vehicle_id: str, originator: str,
                          labs: set, cars: set) -> dict[str, Any]:
    """s_r, the s used for U_meas and the source rule (see the module docstring).

    Returns
    -------
    dict
        ``s_r``, ``s`` (the relative spread U_meas is built from), ``different_source``,
        ``basis`` (which figure and why) and ``provenance``; None values when the packaged
        defaults hold nothing for the procedure.
    """
    try:
        d = precision_default(procedure, family)
    except ConfigError as exc:
        return {"s_r": None, "s": None, "different_source": None, "basis": str(exc),
                "provenance": ""}
    if (vehicle_id, originator) in labs:
        order, why = ("s_r", "s_R", "s_R_vehicle"), "calibrated on this lab's rows of this car"
    elif vehicle_id in cars:
        order, why = ("s_R", "s_R_vehicle", "s_r"), "calibrated on this car in the other lab"
    else:
        order, why = ("s_R_vehicle", "s_R", "s_r"), "not calibrated on this car's rows"
    name = next((q for q in order if getattr(d, q) is not None), None)
    s_r = d.s_r if d.s_r is not None else (getattr(d, name) if name else None)
    return {"s_r": s_r, "s": None if name is None else getattr(d, name),
            "different_source": name is not None and name != "s_r",
            "basis": f"{why}: {name or 'none'} of {d.family} {procedure}"
                     + ("" if name == order[0] else f" ({order[0]} not available)"),
            "provenance": d.provenance}


def check_model_u(method: str, draws: int) -> None:
    """Refuse an unknown ``--model-uncertainty`` or too few draws (before any simulation)."""
    if method not in MODEL_U_METHODS:
        raise ConfigError(f"--model-uncertainty {method.replace('_', '-')}: use one of "
                          f"{', '.join(m.replace('_', '-') for m in MODEL_U_METHODS)}")
    if method != "none":
        check_method(method, draws)


def model_uncertainties(veh: Vehicle, procedures: set[str], method: str = "linear",
                        draws: int = 200, seed: int = 0) -> dict[str, FigureUncertainty | None]:
    """U_model of each procedure's cycle (None: no cycle, or ``method`` ``none``)."""
    check_model_u(method, draws)
    out: dict[str, FigureUncertainty | None] = {}
    for proc in sorted(procedures):
        cyc = PROCEDURE_CYCLE.get(proc)
        out[proc] = (None if cyc is None or method == "none" else
                     figure_uncertainty(veh, cyc, method=method, draws=draws, seed=seed))
    return out


def _set_figures(comparisons: list, in_sample: bool = False) -> list:
    """Judged figures, one per test: whole test when judged, else bags 3+4; held-out tests
    only unless ``in_sample``."""
    by_test: dict[str, list] = {}
    for c in comparisons:
        if (c.judged and (in_sample or not c.in_sample) and not c.sample_unknown
                and c.en is not None):
            by_test.setdefault(c.test, []).append(c)
    out = []
    for rows in by_test.values():
        pick = next((c for c in rows if c.item == "overall"), None) or next(
            (c for c in rows if c.item == "bags 3+4"), None)
        if pick is not None:
            out.append(pick)
    return out


def judge(val: Any, veh: Vehicle, every: list[EpaTest], *, method: str = "linear",
          draws: int = 200, seed: int = 0) -> None:
    """Add En, U_model, U_meas and the uninformative flag to every figure of ``val`` (an
    :class:`~vehval.epa.validation.EpaValidation`) and its set verdict (in place)."""
    family = "hybrid" if architecture(veh).has_battery else "conventional"
    labs, cars = _sources(val.calibrated, every)
    mu = model_uncertainties(veh, {c.procedure for c in val.comparisons}, method, draws, seed)
    val.model_uncertainty = {p: (None if f is None else f.to_dict()) for p, f in mu.items()}
    if method == "none":
        val.notes.append("model uncertainty not propagated (--model-uncertainty none): "
                         "U_model = 0")
    for p, f in mu.items():
        if f is not None and f.method == "none":
            val.notes.extend(n for n in f.notes if n not in val.notes)
        elif f is None and method != "none":
            val.notes.append(f"{p}: no cycle to propagate the model uncertainty on; "
                             "U_model = 0")
    for c in val.comparisons:
        prec = measurement_precision(c.procedure, family, c.vehicle_id, c.originator,
                                     labs, cars)
        f = mu.get(c.procedure)
        u_model = 0.0 if f is None else f.u_rel * abs(c.predicted_mpg)
        c.precision = prec
        if prec["s"] is None or not (c.measured_mpg > 0):
            continue
        u_meas = measurement_uncertainty(c.measured_mpg, s_r=prec["s_r"], s_R=prec["s"],
                                         different_source=prec["different_source"])
        cmp = normalised_error(c.predicted_mpg, c.measured_mpg, u_model, u_meas, label=c.test)
        c.en, c.u_model, c.u_meas, c.uninformative = cmp.en, u_model, u_meas, cmp.uninformative
        c.verdict = cmp
    val.set_verdict, val.set_verdict_note = _verdict(_set_figures(val.comparisons))
    if any(c.in_sample and c.en is not None for c in val.comparisons):
        val.set_verdict_all, val.set_verdict_all_note = _verdict(
            _set_figures(val.comparisons, in_sample=True))


def _verdict(figs: list) -> tuple[dict[str, Any] | None, str]:
    if not figs:
        return None, "no judged figure with an En"
    s_r = math.sqrt(sum(c.precision["s_r"] ** 2 for c in figs) / len(figs))
    diff = [c for c in figs if c.precision["different_source"]]
    s_R = math.sqrt(sum(c.precision["s"] ** 2 for c in diff) / len(diff)) if diff else None
    try:
        sv = set_verdict([c.verdict for c in figs], s_r=s_r, s_R=s_R,
                         different_source=bool(diff))
    except InsufficientDataError as exc:
        return None, str(exc)
    out = sv.to_dict()
    out.update(figures=[f"{c.test} {c.procedure} {c.item}" for c in figs], s_r=s_r, s_R=s_R,
               different_source=bool(diff))
    return out, ""
