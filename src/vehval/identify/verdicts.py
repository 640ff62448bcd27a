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

_KEYS = ("en", "consistent", "u_model_g", "u_meas_g", "uninformative", "s_r")


def _judge(r: dict[str, Any], meas: float, pred: float, s_r: float, label: str) -> Any:
    """Add the En keys to one row (None where the figure is missing); the Comparison."""
    if not (math.isfinite(meas) and meas > 0 and math.isfinite(pred)):
        r.update(dict.fromkeys(_KEYS))
        return None
    h = r.get("pi95_rel")
    u_model = 0.0 if h is None else h * abs(pred)
    u_meas = measurement_uncertainty(meas, u_result=r.get("results_fuel_U_g") or 0.0, s_r=s_r)
    c = normalised_error(pred, meas, u_model, u_meas, label=label)
    r.update(en=None if not math.isfinite(c.en) else c.en,
             consistent=c.consistent, u_model_g=u_model, u_meas_g=u_meas,
             uninformative=c.uninformative, s_r=s_r)
    return c


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
    s_rs = []
    for r in rows:
        d, note = cycle_precision(r.get("cycle"), "conventional")
        s_r = d.s_r if d.s_r is not None else 0.0
        if note:
            notes.append(f"{r['test']}: {note}")
        c = _judge(r, r["fuel_measured_g"], r["fuel_predicted_g"], s_r, r["test"])
        for p in r.get("phases", []):
            _judge(p, p["measured_g"], p["predicted_g"], s_r, f"{r['test']} {p['phase']}")
        if c is not None and not r.get("in_sample"):
            held.append(c)
            s_rs.append(s_r)
    if any(r.get("pi95_rel") is None for r in rows):
        notes.append("a vehicle without identification uncertainty: U_model = 0")
    try:
        sv = set_verdict(held, s_r=math.sqrt(sum(s * s for s in s_rs) / len(s_rs))
                         if s_rs else 0.0)
    except InsufficientDataError as exc:
        notes.append(f"no set verdict: {exc}")
        return None, sorted(set(notes))
    out = sv.to_dict()
    out["tests"] = [c.label for c in held]
    return out, sorted(set(notes))
