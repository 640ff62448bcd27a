"""Several tests validated one by one (``vehval validate`` of an architecture without the
tolerance ladder: battery-electric, parallel hybrid, conventional): each test's
comparison as its architecture makes it (:mod:`vehval.architectures`), judged by the
normalised error of the figure it names (``verdict()`` of the comparison: the DC battery
energy, the net battery energy, the fuel mass), in-sample tests marked."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

from vehval import progress
from vehval.errors import ConfigError
from vehval.workflow.run import TestRun, ValidationOutcome


@dataclass
class EachOutcome:
    """Tests validated one by one.

    Attributes
    ----------
    runs, validations : list
        The runs and their validation outcomes, in the same order.
    verdicts : list of dict
        Per test: ``test_id``, ``figure``, ``en``, ``consistent``, ``model``, ``measured``,
        ``u_model``, ``u_meas`` (k = 2), ``s_r``, ``in_sample``, ``text`` (the comparison's
        ``verdict()``).
    set_verdict : dict or None
        The held-out tests' set verdict (:func:`vehval.validate.ladder.held_out_set_verdict`),
        None with fewer than 3 (``set_verdict_note`` says why).
    payload : dict
        ``validation.json``: report tables, figures and notes of every test.
    metrics : dict
        ``metrics.json``: each test's document and verdict.
    """

    runs: list[TestRun]
    validations: list[ValidationOutcome]
    verdicts: list[dict[str, Any]]
    payload: dict
    metrics: dict
    set_verdict: dict[str, Any] | None = None
    set_verdict_note: str = ""

    def lines(self) -> list[str]:
        """One line per test and the count of consistent held-out tests."""
        out = []
        for v in self.verdicts:
            en = v.get("en")
            word = ("no En" if en is None else "consistent" if v.get("consistent")
                    else "inconsistent")
            out.append(f"{v['test_id']}: {v['text']}: "
                       + (f"En {en:+.2f} " if en is not None else "") + word
                       + (" (in-sample)" if v["in_sample"] else ""))
        held = [v for v in self.verdicts if not v["in_sample"] and v.get("en") is not None]
        ok = sum(1 for v in held if v.get("consistent"))
        text = f"held-out: {ok}/{len(held)} consistent (|En| <= 1)"
        if self.set_verdict is not None:
            from vehval.uncertainty import verdict_text

            text += "; " + verdict_text(self.set_verdict)
        else:
            text += f"; no set verdict ({self.set_verdict_note})"
        out.append(text)
        return out


def validate_each(runs: Sequence[TestRun], *, dt: float = 0.1, window_s: float = 2.0,
                  smooth_hz: float | None = None) -> EachOutcome:
    """Validate each run with its architecture's comparison and judge it by its verdict."""
    from vehval.architectures import stages
    from vehval.calibration.provenance import calibration_tests, in_sample

    if not runs:
        raise ConfigError("no test to validate")
    veh = runs[0].vehicle
    if veh is None:
        raise ConfigError("validation needs a vehicle model: pass --vehicle or set 'vehicle:' "
                          "in the template")
    if stages(veh).validate is None:
        raise ConfigError(f"vehicle '{veh.name}' is '{stages(veh).name}': no validation "
                          f"for it; {stages(veh).hint}")
    calibrated = calibration_tests(veh)
    progress.add(len(runs))
    vals, verdicts, docs = [], [], []
    payload: dict[str, Any] = {
        "title": "Validation", "intro": f"{veh.name} simulated on each test's own speed "
        "trace, mass and road load", "tables": [], "figures": [], "notes": []}
    for run in runs:
        out = run.validate(dt=dt, window_s=window_s, smooth_hz=smooth_hz)
        tid = str(run.validated.meta.test_id)
        verdict = {"test_id": tid, **out.comparison.verdict(),
                   "in_sample": in_sample(veh, tid, calibrated)}
        p = out.comparison.payload()
        payload["tables"] += p["tables"]
        payload["figures"] += p["figures"]
        payload["notes"] += [f"{tid}: {n}" for n in p["notes"]]
        vals.append(out)
        verdicts.append(verdict)
        docs.append({**out.document, "verdict": verdict})
        progress.advance()
    sv, why = _set_verdict(verdicts)
    metrics = {"vehicle": veh.name, "vehicle_file": veh.file, "architecture": stages(veh).name,
               "dt_s": dt, "tests": docs, "set_verdict": sv, "set_verdict_note": why}
    return EachOutcome(list(runs), vals, verdicts, payload, metrics, sv, why)


def _set_verdict(verdicts: list[dict[str, Any]]) -> tuple[dict[str, Any] | None, str]:
    """The set verdict over the held-out tests with an En (and, for a prediction, inside
    the identification's conditions: ``in_set``)."""
    from vehval.uncertainty import normalised_error
    from vehval.validate.ladder import held_out_set_verdict

    judged = [(normalised_error(v["model"], v["measured"], v["u_model"] or 0.0,
                                v["u_meas"] or 0.0, label=v["test_id"]), v.get("s_r") or 0.0)
              for v in verdicts if not v["in_sample"] and v.get("in_set", True)
              and v.get("en") is not None and v.get("u_meas") is not None]
    return held_out_set_verdict(judged)
