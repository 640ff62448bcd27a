"""Summary of a fleet run: counts, error distributions per procedure and technology, outliers.

Works on the row records of :mod:`vehval.epa.fleet` (``error`` = predicted / measured - 1).
Only judged rows (run, list figures consistent; never an analytically derived row, which is
not run) enter the error statistics.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from typing import Any, Sequence

import numpy as np

from vehval.epa.fleet_floor import data_floor, twin_check

#: an outlier lies beyond this many robust standard deviations (1.4826 x MAD) of its
#: procedure's median error, or beyond :data:`OUTLIER_ABS`
OUTLIER_SIGMA = 3.0
OUTLIER_ABS = 0.10
#: technology groupings of the report: record column -> name
GROUPINGS = {"aspiration": "engine", "transmission_class": "transmission",
             "cylinders": "cylinders"}


def judged(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows whose error counts: run, judged, with a predicted and measured figure."""
    return [r for r in records if r.get("status") == "run" and r.get("judged")
            and r.get("error") is not None]


def error_stats(err: Sequence[float]) -> dict[str, Any]:
    """n, median and mean error, median |error|, shares within 3 % and 5 % [-]."""
    a = np.asarray(err, float)
    if not a.size:
        return {"n": 0}
    return {"n": int(a.size), "median_error": float(np.median(a)),
            "mean_error": float(a.mean()), "median_abs_error": float(np.median(np.abs(a))),
            "share_within_3pct": float(np.mean(np.abs(a) <= 0.03)),
            "share_within_5pct": float(np.mean(np.abs(a) <= 0.05))}


def per_procedure(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    by: dict[str, list[float]] = defaultdict(list)
    for r in rows:
        by[r["procedure"]].append(r["error"])
    return {p: error_stats(e) for p, e in sorted(by.items())}


def per_technology(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Grouping -> group -> procedure -> :func:`error_stats`."""
    out: dict[str, Any] = {}
    for col, name in GROUPINGS.items():
        by: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for r in rows:
            by[str(r.get(col) or "unknown")].append(r)  # cylinders 0: not listed
        order = sorted(by, key=lambda g: (not g.isdigit(), int(g) if g.isdigit() else 0, g))
        out[name] = {g: per_procedure(by[g]) for g in order}
    return out


def hwfet_ftp_bias(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Mean over cars with both of (1 + HWFET error) / (1 + FTP-75 error) - 1 [-]."""
    cars: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        cars[r["car"]][r["procedure"]].append(r["error"])
    ratios = [(1 + np.mean(d["hwfet"])) / (1 + np.mean(d["ftp75"])) - 1
              for d in cars.values() if d.get("hwfet") and d.get("ftp75")]
    return {"n_cars": len(ratios), "mean": float(np.mean(ratios)) if ratios else None}


def outliers(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Rows beyond :data:`OUTLIER_SIGMA` robust sigma of their procedure or beyond
    :data:`OUTLIER_ABS`, largest |error| first, each with why."""
    by: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        by[r["procedure"]].append(r)
    out = []
    for proc, rs in by.items():
        e = np.array([r["error"] for r in rs])
        med = float(np.median(e))
        sigma = 1.4826 * float(np.median(np.abs(e - med)))
        for r in rs:
            z = (r["error"] - med) / sigma if sigma > 0 else 0.0
            why = []
            if abs(z) > OUTLIER_SIGMA:
                why.append(f"{z:+.1f} robust sigma from the {proc} median")
            if abs(r["error"]) > OUTLIER_ABS:
                why.append(f"|error| over {100 * OUTLIER_ABS:g} %")
            if why:
                out.append({k: r[k] for k in ("row_id", "make", "model", "vehicle_id",
                                              "procedure", "transmission_class", "aspiration",
                                              "measured_mpg", "predicted_mpg", "error")}
                           | {"robust_z": z, "why": "; ".join(why)})
    return sorted(out, key=lambda o: -abs(o["error"]))


def verdicts(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per procedure: rows with a normalised error, the share with |En| <= 1 (consistent
    within the list's reproducibility and the coefficients' intervals) and the median |En|."""
    by: dict[str, list[float]] = defaultdict(list)
    for r in rows:
        if r.get("en") is not None:
            by[r["procedure"]].append(abs(r["en"]))
    return {p: {"n": len(v), "share_consistent": float(np.mean(np.array(v) <= 1.0)),
                "median_abs_en": float(np.median(v))} for p, v in sorted(by.items())}


def _judged_block(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Judged rows' statistics: counts (in-sample: the row's list is one the technology
    coefficients were fitted on), errors per procedure, share within 5 %, HWFET/FTP bias,
    normalised-error verdicts."""
    err = [r["error"] for r in rows]
    return {"n_judged": len(rows), "n_in_sample": sum(bool(r.get("in_sample")) for r in rows),
            "errors": per_procedure(rows),
            "share_within_5pct": float(np.mean(np.abs(err) <= 0.05)) if err else None,
            "hwfet_ftp_bias": hwfet_ftp_bias(rows), "verdicts": verdicts(rows)}


#: the issue's acceptance targets of the fleet model, judged out of sample
TARGETS = {"median_abs_error": 0.03, "share_within_5pct": 0.80, "hwfet_ftp_bias": 0.02,
           "group_bias": 0.03}
#: least rows of a technology group whose median bias is judged
MIN_GROUP_ROWS = 20


def worst_group_bias(per_tech: dict[str, Any]) -> dict[str, Any] | None:
    """The technology group and procedure with the largest |median error| among groups of
    :data:`MIN_GROUP_ROWS` rows or more (``unknown``, rows whose list leaves the column
    blank, is not a technology: left out)."""
    best = None
    for grouping, groups in per_tech.items():
        for g, procs in groups.items():
            if g == "unknown":
                continue
            for p, st in procs.items():
                if st.get("n", 0) >= MIN_GROUP_ROWS and (
                        best is None or abs(st["median_error"]) > abs(best["median_error"])):
                    best = {"grouping": grouping, "group": g, "procedure": p,
                            "n": st["n"], "median_error": st["median_error"]}
    return best


def fleet_model(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The physics + learned residual judged out of sample (year to year when the run has
    it, else within a year; rows in the technology coefficients' fit left out), against
    :data:`TARGETS`: errors per procedure, share within 5 %, HWFET/FTP bias, technology
    groups and the worst group's median bias; ``floor``: what a perfect model of the row's
    columns would reach on these lists (:func:`vehval.epa.fleet_floor.data_floor`) and, year
    to year, under ``floor.twins``, the fit lists' near twins against the fleet model
    (:func:`vehval.epa.fleet_floor.twin_check`)."""
    year = any(r.get("residual_year_error") is not None for r in records)
    key = "residual_year_error" if year else "residual_error"
    rows = [{**r, "error": r[key], "en": r.get("residual_en") if year else None}
            for r in judged(records) if not r.get("in_sample") and r.get(key) is not None]
    if not rows:
        return {"scheme": None, "n_judged": 0}
    tech = per_technology(rows)
    lists = sorted({r["list"] for r in rows})
    block = {"scheme": "year_to_year" if year else "within_year", "error_key": key,
             **_judged_block(rows),
             "per_list": {k: {key_: v for key_, v in _judged_block(
                 [r for r in rows if r["list"] == k]).items() if key_ != "n_in_sample"}
                 for k in lists},
             "per_technology": tech, "worst_group_bias": worst_group_bias(tech)}
    worst = block["worst_group_bias"]
    bias = block["hwfet_ftp_bias"]["mean"]
    block["floor"] = data_floor(judged(records),
                                {p: st["n"] for p, st in block["errors"].items()})
    if year:
        every = sorted({r["list"] for r in judged(records)})
        block["floor"]["twins"] = twin_check(judged(records), key,
                                             {k: set(every) - {k} for k in lists})
    block["targets"] = TARGETS
    block["met"] = {
        "median_abs_error": {p: st["median_abs_error"] <= TARGETS["median_abs_error"]
                             for p, st in block["errors"].items()},
        "share_within_5pct": block["share_within_5pct"] >= TARGETS["share_within_5pct"],
        "hwfet_ftp_bias": bias is not None and abs(bias) <= TARGETS["hwfet_ftp_bias"],
        "group_bias": worst is None or abs(worst["median_error"]) <= TARGETS["group_bias"]}
    return block


def summarise(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The JSON summary of a fleet run's records (keys documented in docs/fleet.md)."""
    rows = judged(records)
    status = Counter(r["status"] for r in records)
    per_list: dict[str, Counter] = defaultdict(Counter)
    for r in records:
        per_list[r["list"]][r["status"]] += 1
    outside = [r for r in rows if not r.get("in_sample")]
    lists = {}
    for k, c in sorted(per_list.items()):
        out_k = [r for r in outside if r["list"] == k]
        lists[k] = {"n_rows": sum(c.values()), "n_run": c["run"], "n_not_run": c["not_run"],
                    "n_failed": c["failed"], **_judged_block([r for r in rows if r["list"] == k]),
                    "out_of_sample": {**_judged_block(out_k),
                                      "per_technology": per_technology(out_k)}}
    out: dict[str, Any] = {
        "n_rows": len(records), "n_run": status["run"], "n_not_run": status["not_run"],
        "n_failed": status["failed"], "n_judged": len(rows),
        "n_cars": len({r["car"] for r in records if r["status"] == "run"}),
        "not_run_by_reason": dict(Counter(r["reason_code"] for r in records
                                          if r["status"] != "run").most_common()),
        "per_list": lists,
        "errors": per_procedure(rows),
        "per_technology": per_technology(rows),
        "hwfet_ftp_bias": hwfet_ftp_bias(rows),
        "outliers": outliers(rows),
        "out_of_sample": {**_judged_block(outside), "per_technology": per_technology(outside)},
        "fleet_model": fleet_model(records),
    }
    out["notes"] = [f"{k}: no runnable row (rows not run: "
                    + ", ".join(f"{c} {n}" for c, n in Counter(
                        r["reason_code"] for r in records if r["list"] == k).most_common())
                    + ")" for k, v in lists.items() if not v["n_run"]]
    return out


def finite(x: Any) -> Any:
    """None for NaN or infinity (JSON)."""
    return None if isinstance(x, float) and not math.isfinite(x) else x
