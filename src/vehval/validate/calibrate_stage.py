"""`vehval calibrate` of a power-split hybrid as one stage: start values checked before any
test is read, the differential-evolution search on QA's validated tests
(:func:`vehval.validate.calibration.calibrate`), the outcome's document, files and lines."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass
class CalibrationStage:
    """A calibration's outcome: ``result`` (with ``to_dict`` and ``write_vehicle``), the
    ``calibration.json`` text and the lines on screen."""

    result: Any
    document: dict[str, Any]
    text: str
    lines: list[str]

    def write(self, outdir: Path) -> None:
        """``calibration.json`` and ``vehicle_calibrated.yaml`` into ``outdir``."""
        (outdir / "calibration.json").write_text(self.text, encoding="utf-8")
        self.result.write_vehicle(outdir / "vehicle_calibrated.yaml")


def _cycle(cycle: str | None) -> str:
    return cycle or "no cycle identified"


def _pct(value: Any, digits: int, unit: str = " %") -> str:
    import math

    if value is None or not math.isfinite(float(value)):
        return "n/a"
    return f"{float(value):.{digits}f}{unit}"


def calibrate_power_split(veh: Any, load: Callable[..., tuple[list, list]], opts: dict[str, Any],
                          bar: Any) -> CalibrationStage:
    """Tune the dotted ``opts["params"]`` (comma-separated) of a power-split ``veh`` on the
    tests ``load(per_file=False, use_qa=True)`` gives (tuning runs, held-out runs), from the
    start values of the JSON ``opts["start"]`` (checked first: finite, inside the bounds);
    ``opts`` also holds the search's ``dt`` [s], ``popsize``, ``maxiter``, ``seed``,
    ``mode`` and ``smooth_hz`` [Hz]; ``bar(label)`` shows its progress."""
    params, start, maxiter = opts["params"], opts["start"], opts["maxiter"]
    from vehval import progress
    from vehval.validate.calibration import calibrate, check_start
    from vehval.validate.calibration import start_values as parse_start
    from vehval.validate.conditions import full_name

    names = [p.strip() for p in (params or "").split(",") if p.strip()]
    start_values = None
    if start is not None:       # checked before any test is read: finite, inside the bounds
        from vehval.safe_yaml import read_json

        start_values = read_json(start)
        full = [full_name(n) for n in names]
        check_start(veh, parse_start(start_values, full), full)
    tune, hold = load(per_file=False, use_qa=True)
    with bar("calibrate: generations (at most)"):
        progress.add(maxiter)
        res = calibrate([r.validated for r in tune], veh, names, start=start_values,
                        holdout_tests=[r.validated for r in hold], dt=opts["dt"],
                        popsize=opts["popsize"], maxiter=maxiter, seed=opts["seed"],
                        mode=opts["mode"], smooth_hz=opts["smooth_hz"],
                        progress=lambda _i, _j: progress.advance())
    doc = res.to_dict()
    return CalibrationStage(res, doc, json.dumps(doc, indent=1) + "\n", _lines(res))


def _lines(res: Any) -> list[str]:
    out = [f"note: {note}" for note in res.notes]
    out += [f"{n}: {res.start[n]:.6g} -> {res.best[n]:.6g}" for n in res.parameters]
    for row in res.rows():
        out.append(f"{row[0]} ({_cycle(row[1])}): fuel error {_pct(row[2], 2, '')} -> "
                   f"{_pct(row[3], 2)}, SOC error {_pct(row[4], 2, '')} -> {_pct(row[5], 2)}")
    for tid in res.holdout:
        en = res.after.get(tid, {}).get("en")
        if en is not None:
            out.append(f"{tid} (held out): fuel En after calibration {en:+.2f} "
                       f"({'consistent' if abs(en) <= 1 else 'inconsistent'}; U_model = 0)")
    sv, why = res.holdout_verdict()
    if res.holdout:
        out.append("held-out set verdict: " + (f"{sv['verdict']} (n = {sv['n']}, mean fuel "
                   f"error {sv['mean_error_pct']:+.2f} %)" if sv else f"none ({why})"))
    out.append(f"objective {res.objective_start:.4g} -> {res.objective_best:.4g} "
               f"({res.n_simulations} simulations, {res.elapsed_s:.1f} s)")
    out.append(res.tables()[1]["note"])
    return out
