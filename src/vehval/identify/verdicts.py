"""Normalised error of ``vehval predict`` (and the cross-validation): fuel per test and phase.

Per prediction row (a test, and each of its phases) with fuel mass in g, k = 2:

* **U_model**: the identified model's 95 % prediction interval
  (:mod:`vehval.identify.uncertainty`, ``pi95_rel`` x predicted; 1.96 sigma taken as k = 2);
  0 for a vehicle without identification uncertainty (stated).
* **U_meas**: the results stage's expanded uncertainty of the measured fuel
  (``results_fuel_U_g``, the channels' declared accuracies; 0 without results) combined with
  the repeatability s_r of the test's procedure, conventional family
  (:func:`vehval.uncertainty.defaults.cycle_precision`). The model was identified on tests
  of the same car in the same lab (``predict`` checks the car), so s_r, not s_R. A phase
  takes its test's s_r.

The keys added to a row: ``en``, ``consistent``, ``u_model_g``, ``u_meas_g``,
``uninformative``, ``s_r``; the set verdict (:func:`vehval.uncertainty.set_verdict`) of the
held-out (not in-sample) whole-test rows is returned by :func:`judge_rows`.
"""

from __future__ import annotations

import math
from typing import Any

from vehval.uncertainty import InsufficientDataError, normalised_error, set_verdict
from vehval.uncertainty.defaults import cycle_precision
from vehval.uncertainty.verdict import measurement_uncertainty
from vehval.validate.ladder import in_set_verdict

#: keys added to a row and a phase
EN_KEYS = ("en", "consistent", "u_model_g", "u_meas_g", "uninformative", "s_r")


def _judge(r: dict[str, Any], meas: float, pred: float, s_r: float, label: str) -> Any:
    """Add the En keys to one row (None where the figure is missing); the Comparison."""
    if not (math.isfinite(meas) and meas > 0 and math.isfinite(pred)):
        r.update(dict.fromkeys(EN_KEYS))
        return None
    h = r.get("pi95_rel")
    u_model = 0.0 if h is None else h * abs(pred)
    u_meas = measurement_uncertainty(meas, u_result=r.get("results_fuel_U_g") or 0.0, s_r=s_r)
    c = normalised_error(pred, meas, u_model, u_meas, label=label)
    r.update(en=None if not math.isfinite(c.en) else c.en,
             consistent=c.consistent, u_model_g=u_model, u_meas_g=u_meas,
             uninformative=c.uninformative, s_r=s_r)
    return c


def judge_row(r: dict[str, Any]) -> tuple[Any, float, str]:
    """Add the En keys to one ``predict_trace`` row and its phases (in place).

    Returns
    -------
    comparison : vehval.uncertainty.Comparison or None
        Of the whole test (None without a fuel figure).
    s_r : float
        The repeatability used [-].
    note : str
        Empty, or the cycle whose precision was borrowed.
    """
    d, note = cycle_precision(r.get("cycle"), "conventional")
    s_r = d.s_r if d.s_r is not None else 0.0
    c = _judge(r, r["fuel_measured_g"], r["fuel_predicted_g"], s_r, r["test"])
    for p in r.get("phases", []):
        _judge(p, p["measured_g"], p["predicted_g"], s_r, f"{r['test']} {p['phase']}")
    return c, s_r, (f"{r['test']}: {note}" if note else "")


def verdict_of(judged: list[tuple[Any, float]]) -> tuple[dict[str, Any] | None, str]:
    """Set verdict of (comparison, s_r) pairs with the root mean square s_r; (None, reason)
    with fewer than 3."""
    s_r = math.sqrt(sum(s * s for _, s in judged) / len(judged)) if judged else 0.0
    try:
        sv = set_verdict([c for c, _ in judged], s_r=s_r)
    except InsufficientDataError as exc:
        return None, f"no set verdict: {exc}"
    out = sv.to_dict()
    out["tests"] = [c.label for c, _ in judged]
    return out, ""


def judge_rows(rows: list[dict[str, Any]]) -> tuple[dict[str, Any] | None, list[str]]:
    """Add En to every row and phase of ``rows`` (``predict_trace`` results, in place).

    Returns
    -------
    set_verdict : dict or None
        Of the held-out whole-test rows (None with fewer than 3; the reason in notes).
    notes : list of str
    """
    notes: list[str] = []
    held = []
    for r in rows:
        c, s_r, note = judge_row(r)
        if note:
            notes.append(note)
        if c is None or r.get("in_sample"):
            continue
        if in_set_verdict(r):
            held.append((c, s_r))
        else:
            notes.append(f"{r['test']}: outside the identification's conditions: not in "
                         "the set verdict")
    if any(r.get("pi95_rel") is None for r in rows):
        notes.append("a vehicle without identification uncertainty: U_model = 0")
    verdict, why = verdict_of(held)
    if why:
        notes.append(why)
    return verdict, sorted(set(notes))
