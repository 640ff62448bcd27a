"""Cross-validation of identification: identify from some tests, predict the others.

``leave-one-out`` (default): for each test, the car is identified from all the others and
that test is predicted. ``pairs``: for every pair of tests of distinct cycles, the car is
identified from the pair and every other test is predicted. Each prediction carries its
95 % prediction interval and the share of its fuel from operating points the pair did not
cover (:mod:`vehval.identify.uncertainty`); the summary counts how often the interval
holds the measured fuel. Identification skips the drag-share evidence curve here (it only
documents the assumption; the identified values are the same).
"""

from __future__ import annotations

import itertools
import multiprocessing as mp
import os
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from vehval.identify.traces import IdentificationError, Trace, dead_fuel_channel
from vehval.identify.verdicts import EN_KEYS, judge_row, verdict_of
from vehval.uncertainty import normalised_error
from vehval.validate.ladder import in_set_verdict

COLUMNS = ("identified_from", "test", "cycle", "measured_g", "predicted_g", "error_rel",
           "pi95_rel", "pi95_g", "inside_pi95", "uncovered_share", "n_gears")


def _combos(traces: list[Trace], pairs: bool) -> tuple[list[tuple[int, ...]], list[str]]:
    n = len(traces)
    if n < 2:
        names = ", ".join(t.test_id for t in traces) or "none"
        raise IdentificationError(
            f"cross-validation: one test given ({names}); it needs at least two (identify "
            "from some, predict the others)" + ("; with --pairs at least three" if pairs else ""))
    dead = {i: why for i, t in enumerate(traces) if (why := dead_fuel_channel(t))}
    unjudged = [f"{why}: not predicted (no measured fuel to judge)" for why in dead.values()]
    if not pairs:
        return ([tuple(j for j in range(n) if j != i) for i in range(n) if i not in dead],
                unjudged)
    if n < 3:
        raise IdentificationError(
            f"cross-validation --pairs: {n} tests given; a pair leaves nothing to predict: give "
            "at least three tests")
    out: list[tuple[int, ...]] = []
    skipped: list[str] = unjudged
    for i, j in itertools.combinations(range(n), 2):
        ci, cj = traces[i].cycle.lower(), traces[j].cycle.lower()
        if ci and ci == cj:
            skipped.append(f"{traces[i].test_id} + {traces[j].test_id}: same cycle ({ci})")
        else:
            out.append((i, j))
    return out, skipped


def _run_combo(arg) -> list[dict]:
    """Identify from one set of tests and predict the others (one worker's job)."""
    from vehval.identify.build import identify_conventional
    from vehval.identify.predict import predict_trace

    traces, combo, declared, ac = arg
    used = [traces[i] for i in combo]
    names = [t.test_id for t in used]
    held = [t for k, t in enumerate(traces) if k not in combo and not dead_fuel_channel(t)]
    try:
        idf = identify_conventional(used, "cross_validation", declared=declared,
                                    drag_evidence=False)
    except IdentificationError as exc:
        return [{"identified_from": names, "test": t.test_id, "cycle": t.cycle,
                 "error": str(exc)} for t in held]
    rows = []
    for t in held:
        p = predict_trace(idf.vehicle, t, ac=ac)
        judge_row(p)   # En of the test and its phases (vehval.identify.verdicts)
        lo_hi = p.get("pi95_g")
        rows.append({
            "identified_from": names, "test": t.test_id, "cycle": t.cycle,
            "measured_g": p["fuel_measured_g"], "predicted_g": p["fuel_predicted_g"],
            "error_rel": p["error_rel"], "pi95_rel": p.get("pi95_rel"), "pi95_g": lo_hi,
            "inside_pi95": (None if lo_hi is None else
                            bool(lo_hi[0] <= p["fuel_measured_g"] <= lo_hi[1])),
            "uncovered_share": p.get("uncovered_share"), "n_gears": len(idf.gears.ratios),
            "gear_notes": idf.gears.notes,
            "outside_identification": bool(p.get("outside_identification")),
            **{k: p.get(k) for k in EN_KEYS},
            "phases": [{k: ph.get(k) for k in ("phase", "measured_g", "predicted_g",
                                               "error_rel", "pi95_rel", "uncovered_share",
                                               *EN_KEYS)}
                       for ph in p["phases"]]})
    return rows


def cross_validate(traces: list[Trace], pairs: bool = False, declared: dict | None = None,
                   ac: str = "auto", jobs: int | None = None) -> dict:
    """Predicted vs measured fuel of each held-out test (see the module docstring).

    The identifications run in up to ``jobs`` processes (default: the CPU count, at most 2;
    each holds the traces, a few tens of MB).

    Returns
    -------
    dict with ``mode`` (``leave-one-out`` or ``pairs``), ``rows`` (one per prediction, keys
    :data:`COLUMNS`, plus ``error`` instead of the figures when the identification from that
    set failed), ``skipped`` (pairs of one cycle), ``summary`` {``n_predictions``,
    ``median_abs_error``, ``mean_abs_error``, ``max_abs_error``, ``share_within_5pct``,
    ``pi95_coverage``, ``median_pi95_rel``, ``n_failed``} and ``elapsed_s``.
    """

    t0 = time.perf_counter()
    combos, skipped = _combos(traces, pairs)
    args = [(traces, combo, declared, ac) for combo in combos]
    n_jobs = max(1, min(jobs if jobs is not None else (os.cpu_count() or 1), 2, len(combos)))
    if n_jobs > 1 and "fork" in mp.get_all_start_methods():
        with ProcessPoolExecutor(n_jobs, mp_context=mp.get_context("fork")) as pool:
            parts = list(pool.map(_run_combo, args))
    else:
        parts = [_run_combo(a) for a in args]
    rows = [r for part in parts for r in part]
    judged = [(normalised_error(r["predicted_g"], r["measured_g"], r["u_model_g"],
                                r["u_meas_g"], label=r["test"]), r["s_r"])
              for r in rows if r.get("en") is not None and in_set_verdict(r)]
    verdict, why = verdict_of(judged)
    outside = sorted({r["test"] for r in rows if not in_set_verdict(r)})
    if outside:
        why = "; ".join(x for x in (why, "not in the set verdict, outside the identification's "
                                         "conditions: " + ", ".join(outside)) if x)
    return {"mode": "pairs" if pairs else "leave-one-out", "rows": rows, "skipped": skipped,
            "summary": summarise(rows), "elapsed_s": time.perf_counter() - t0,
            "set_verdict": verdict, "set_verdict_note": why}


def summarise(rows: list[dict]) -> dict:
    ok = [r for r in rows if "error" not in r]
    err = np.abs([r["error_rel"] for r in ok]) if ok else np.array([])
    pis = [r for r in ok if r.get("pi95_rel") is not None]
    return {"n_predictions": len(ok), "n_failed": len(rows) - len(ok),
            "median_abs_error": float(np.median(err)) if err.size else None,
            "mean_abs_error": float(np.mean(err)) if err.size else None,
            "max_abs_error": float(np.max(err)) if err.size else None,
            "share_within_5pct": float(np.mean(err <= 0.05)) if err.size else None,
            "pi95_coverage": (float(np.mean([r["inside_pi95"] for r in pis])) if pis else None),
            "median_pi95_rel": (float(np.median([r["pi95_rel"] for r in pis])) if pis else None)}


def table(result: dict) -> str:
    """The cross-validation as text: one line per prediction, then the summary."""
    lines = [f"cross-validation ({result['mode']}): fuel of each held-out test",
             f"{'identified from':<36} {'held-out test':<22} {'cycle':<10} {'measured g':>10} "
             f"{'predicted g':>11} {'error %':>8} {'95 % PI':>8} {'in':>3} {'uncov %':>7} {'En':>6}"]
    for r in result["rows"]:
        src = " + ".join(x.split()[0] for x in r["identified_from"])
        if "error" in r:
            lines.append(f"{src:<36} {r['test']:<22} identification failed: {r['error']}")
            continue
        pi = "" if r["pi95_rel"] is None else f"±{100 * r['pi95_rel']:.1f}"
        inside = "" if r["inside_pi95"] is None else ("yes" if r["inside_pi95"] else "no")
        unc = "" if r["uncovered_share"] is None else f"{100 * r['uncovered_share']:.0f}"
        en = "" if r.get("en") is None else f"{r['en']:+.2f}" + ("?" if r["uninformative"] else "")
        lines.append(f"{src:<36} {r['test']:<22} {r['cycle'][:10]:<10} {r['measured_g']:>10.1f} "
                     f"{r['predicted_g']:>11.1f} {100 * r['error_rel']:>+8.2f} {pi:>8} "
                     f"{inside:>3} {unc:>7} {en:>6}"
                     + ("  outside the identification's conditions"
                        if r.get("outside_identification") else ""))
    if any(r.get("en") is not None and r.get("uninformative") for r in result["rows"]):
        lines.append("En? : uninformative (the combined uncertainty exceeds a tenth of the "
                     "measured fuel: the comparison cannot tell)")
    for s in result["skipped"]:
        lines.append(f"skipped {s}")
    s = result["summary"]
    if s["n_predictions"]:
        lines.append(
            f"{s['n_predictions']} predictions: median |error| {100 * s['median_abs_error']:.2f} %, "
            f"mean {100 * s['mean_abs_error']:.2f} %, max {100 * s['max_abs_error']:.2f} %, "
            f"within 5 %: {100 * s['share_within_5pct']:.0f} %"
            + ("" if s["pi95_coverage"] is None else
               f"; 95 % intervals hold the measurement in {100 * s['pi95_coverage']:.0f} %, "
               f"median half-width {100 * s['median_pi95_rel']:.1f} %")
            + f" ({result['elapsed_s']:.0f} s)")
    sv = result.get("set_verdict")
    if sv is not None:
        from vehval.uncertainty import verdict_text

        lines.append(verdict_text(sv, "held-out predictions"))
    if result.get("set_verdict_note"):
        lines.append(result["set_verdict_note"])
    return "\n".join(lines)
