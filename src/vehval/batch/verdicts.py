"""The set verdict at the end of a batch: bias and coverage over the validated tests.

Each test's validate step records the normalised error of its fuel mass
(``result.json``: ``validation.normalised_error``, see :func:`vehval.batch.task._normalised_error`).
Over the tests of a run, computed now or unchanged since an earlier run, the held-out ones
(not in the vehicle file's calibration set) with an En get the set verdict of
:func:`vehval.validate.ladder.held_out_set_verdict`, one per vehicle, as ``vehval validate``
gives it over its tests.
"""

from __future__ import annotations

import json
from typing import Any, Iterable

from vehval.errors import VehvalError
from vehval.uncertainty import normalised_error
from vehval.validate.ladder import held_out_set_verdict, in_set_verdict


def _judged(res: dict) -> dict | None:
    val = res.get("validation")
    ne = val.get("normalised_error") if isinstance(val, dict) else None
    return ne if isinstance(ne, dict) else None


def batch_set_verdicts(results: Iterable[dict]) -> list[dict[str, Any]]:
    """Set verdicts of a batch, one per vehicle with a validated test.

    Parameters
    ----------
    results : iterable of dict
        The tests' ``result.json`` contents (failed ones are ignored).

    Returns
    -------
    list of dict
        ``vehicle``, ``figure`` (``fuel_mass_kg``), ``n_validated`` (tests with an En),
        ``n_in_sample``, ``tests`` (the test ids judged: held out and inside the
        identification's conditions, :func:`vehval.validate.ladder.in_set_verdict`), ``set_verdict``
        (:meth:`vehval.uncertainty.SetVerdict.to_dict`, None with fewer than 3) and ``note``
        (why there is none).
    """
    groups: dict[str, list[tuple[str, dict]]] = {}
    for res in results:
        ne = _judged(res)
        if res.get("status") == "failed" or ne is None or ne.get("en") is None:
            continue
        groups.setdefault(str(res.get("vehicle") or ""), []).append((str(res["test_id"]), ne))
    out = []
    for veh, tests in sorted(groups.items()):
        held, ids = [], []
        for tid, ne in sorted(tests):
            if not in_set_verdict(ne):  # the rule of `vehval predict`'s set verdict
                continue
            try:
                c = normalised_error(float(ne["model_kg"]), float(ne["measured_kg"]),
                                     float(ne.get("u_model_kg") or 0.0),
                                     float(ne.get("u_meas_kg") or 0.0), label=tid)
            except (KeyError, TypeError, ValueError, VehvalError):
                continue            # an edited result.json: the test is left out
            held.append((c, float(ne.get("s_r") or 0.0)))
            ids.append(tid)
        sv, note = held_out_set_verdict(held)
        out.append({"vehicle": veh, "figure": "fuel_mass_kg", "n_validated": len(tests),
                    "n_in_sample": sum(bool(ne.get("in_sample")) for _, ne in tests),
                    "tests": ids, "set_verdict": sv, "note": note})
    return out


def verdict_line(row: dict) -> str:
    """One screen line: ``set verdict (prius_2004, fuel mass, n = 3): consistent with the
    data; mean error -0.40 % [-1.20, +0.40] ...`` (:func:`vehval.uncertainty.verdict_text`)."""
    from vehval.uncertainty import verdict_text

    sv = row.get("set_verdict")
    what = f"{row.get('vehicle') or '?'}, fuel mass"
    if sv is None:
        return f"set verdict ({what}): none ({row.get('note')})"
    return verdict_text(sv, what)


def stored_set_verdicts(catalog: Any, run_id: str | None = None) -> list[dict]:
    """The set verdicts a catalog holds for ``run_id`` (default: the latest run that has
    any), as :func:`batch_set_verdicts` gave them, each with ``run_id``."""
    if run_id is None:
        _, got = catalog.query("SELECT s.run_id FROM set_verdicts s JOIN runs r USING (run_id) "
                               "ORDER BY r.started DESC LIMIT 1")
        if not got:
            return []
        run_id = got[0][0]
    _, rows = catalog.query("SELECT detail FROM set_verdicts WHERE run_id = ? "
                            "ORDER BY vehicle, figure", [run_id])
    return [{**json.loads(d), "run_id": run_id} for (d,) in rows if d]
