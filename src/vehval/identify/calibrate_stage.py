"""`vehval calibrate` of a conventional car as one stage: every file (or ``--test`` group)
is one test read without QA, the fuel model tuned on their fuel
(:func:`vehval.identify.calibrate.calibrate_conventional`), the outcome's document, files
and lines."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from vehval.errors import ConfigError
from vehval.validate.calibrate_stage import CalibrationStage

#: The power-split default of ``--params``: a conventional car tunes its own defaults then.
HYBRID_DEFAULT = "controller.engine_on_power_w"


def calibrate_conventional_stage(veh: Any, load: Callable[..., tuple[list, list]],
                                 opts: dict[str, Any], bar: Any) -> CalibrationStage:
    """Tune ``params`` of a conventional ``veh`` (the power-split default list: the fuel
    model's :data:`~vehval.identify.calibrate.DEFAULT_PARAMS`) on the raw tests
    ``load(per_file=True, use_qa=False)`` gives, one test per file (``opts``: ``params``,
    ``template``; ``bar(label)`` shows the progress)."""
    params = opts["params"]
    from vehval.identify.calibrate import DEFAULT_PARAMS, calibrate_conventional
    from vehval.identify.traces import trace_from_test
    from vehval.jsonsafe import dumps

    if opts["template"] is None:
        raise ConfigError("calibrate: give the import template with -t for a conventional car")
    names = (list(DEFAULT_PARAMS) if params.startswith(HYBRID_DEFAULT)
             else [p.strip() for p in params.split(",") if p.strip()])
    tune, hold = load(per_file=True, use_qa=False)
    with bar("calibrate: tuning the fuel model"):
        res = calibrate_conventional(veh, [trace_from_test(r.test) for r in tune], names,
                                     [trace_from_test(r.test) for r in hold])
    doc = res.to_dict()
    return CalibrationStage(res, doc, dumps(doc) + "\n", _lines(res))


def _lines(res: Any) -> list[str]:
    from vehval.identify.calibrate import _bounds
    from vehval.validate.calibration import _sample_note

    out = []
    for n in res.parameters:
        lo, hi = _bounds(n, res.start[n])
        edge = next((f"{name} bound {b:.6g}" for name, b in (("lower", lo), ("upper", hi))
                     if abs(res.best[n] - b) <= 1e-3 * max(hi - lo, 1e-12)), None)
        out.append(f"{n}: {res.start[n]:.6g} -> {res.best[n]:.6g}"
                   + (f"  (at its {edge}: not identified, the fuel data push it beyond its "
                      "range)" if edge else ""))
    for row in res.tests:
        mark = ("" if not row["in_sample"] else ", in sample" if row["role"] == "tune" else
                ", in sample: the start vehicle was identified on it")
        out.append(f"{row['test']} ({row['role']}{mark})"
                   f": fuel error {100 * row['error_rel_before']:+.2f}"
                   f" -> {100 * row['error_rel_after']:+.2f} %")
    # the summary line of the power-split calibration: held-out and in-sample apart
    stats: dict[str, dict] = {}
    for role in ("holdout", "tune"):
        rows = [r for r in res.tests if r["in_sample"] == (role == "tune")]
        b, a = (100 * sum(abs(r[k]) for r in rows) / len(rows) if rows else None
                for k in ("error_rel_before", "error_rel_after"))
        stats[role] = {"n_tests": len(rows), "fuel_pct_before": b, "fuel_pct_after": a}
    hb, ha = stats["holdout"]["fuel_pct_before"], stats["holdout"]["fuel_pct_after"]
    worse = hb is not None and ha is not None and ha > hb
    out.append(_sample_note(stats["holdout"], stats["tune"])
               + ("; the held-out tests got worse: the tuning overfits its tests" if worse else ""))
    out.append(f"objective {res.objective_start:.4g} -> {res.objective_best:.4g} "
               f"({res.n_simulations} simulations, {res.elapsed_s:.1f} s)")
    return out
