"""The data's own floor for a model of the list's columns: what a perfect one would reach.

Two judged rows with the same procedure, the same make and the same columns of
:func:`vehval.epa.fleet_baseline.features` (test weight, road load, displacement, power,
cylinders, N/V, axle ratio, gears, transmission class, fuel and aspiration) are one car to
any model that reads those columns: it gives both one figure. Their measured figures still
differ (a repeated test, another test vehicle of the same configuration, another lab, a
calibration the list does not name), and no such model can do better than the spread
within these groups.

Per procedure, each row of a group of ``n >= 2`` gives its log deviation from the group's
mean, scaled by ``sqrt(n / (n - 1))`` (the deviation of one test from the true value, not
from a mean that holds it). Their distribution is the error of a perfect model of the
columns: its median |deviation| and its share within 5 % are the floor of the fleet
targets; the pooled standard deviation (``sigma``, ``dof`` degrees of freedom) is stated
too. The distribution has heavy tails (a few groups differ by over 10 %), so the median
and the share are read from the deviations themselves, not from ``sigma``.

Year to year, :func:`twin_check` asks the same of another list: a judged row whose fit
list holds a near twin (another test vehicle of the same procedure, make, cylinders,
transmission class, gears, fuel and aspiration, every number within
:data:`TWIN_TOLERANCE`) is predicted by the twins' measured figure alone; the fleet model
is read on the same rows and on the rows without a twin, which splits its error into what
the columns tell apart and what is new to the fit list.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any, Sequence

import numpy as np

from vehval.epa.fleet_baseline import features, make_key, road_load

#: least groups of a procedure to state its floor
MIN_GROUPS = 5
#: columns rounded to this many significant digits before grouping (list figures repeated
#: across rows convert to SI identically; the rounding only absorbs float noise)
_DIGITS = 6
#: a near twin's largest relative difference per column [-] (displacement: absolute [L])
TWIN_TOLERANCE = {"mass_kg": 0.01, "n_v_ratio": 0.01, "axle_ratio": 0.01,
                  "rated_power_w": 0.02, "road_load_20": 0.03, "road_load_50": 0.02,
                  "road_load_70": 0.02, "displacement_l": 0.05}
_TWIN_SAME = ("procedure", "cylinders", "transmission_class", "gears", "fuel_family",
              "aspiration")


def _key(r: dict[str, Any]) -> tuple | None:
    x = features(r)
    if x is None:
        return None
    return (r["procedure"], make_key(r),
            tuple(float(f"{v:.{_DIGITS}g}") for v in x))


def data_floor(rows: Sequence[dict[str, Any]],
               mix: dict[str, int] | None = None) -> dict[str, Any]:
    """The floor of a model of the row's columns on judged ``rows`` (records with
    ``procedure`` and ``measured_mpg``).

    Returns ``per_procedure``: procedure -> ``n_groups``, ``n_rows`` (rows in groups of two
    or more), ``dof``, ``sigma`` (pooled standard deviation of one test, log [-]),
    ``median_abs_error`` and ``share_within_5pct`` of a perfect model [-] (procedures with
    fewer than :data:`MIN_GROUPS` groups are left out); and ``share_within_5pct`` over
    procedures weighted by ``mix`` (procedure -> judged rows; default: the groups' rows)."""
    groups: dict[tuple, list[float]] = defaultdict(list)
    for r in rows:
        key = _key(r)
        if key is not None and r.get("measured_mpg"):
            groups[key].append(math.log(r["measured_mpg"]))
    dev: dict[str, list[float]] = defaultdict(list)
    stats: dict[str, list[float]] = defaultdict(lambda: [0, 0, 0.0])
    for (proc, *_), x in groups.items():
        if len(x) < 2:
            continue
        a = np.asarray(x)
        c = a - a.mean()
        n = len(a)
        dev[proc] += list(c * math.sqrt(n / (n - 1)))
        s = stats[proc]
        s[0] += 1
        s[1] += n - 1
        s[2] += float(c @ c)
    per = {}
    for proc in sorted(dev):
        n_groups, dof, ss = stats[proc]
        if n_groups < MIN_GROUPS:
            continue
        d = np.abs(np.expm1(-np.asarray(dev[proc])))  # a perfect prediction's |error|
        per[proc] = {"n_groups": int(n_groups), "n_rows": len(d), "dof": int(dof),
                     "sigma": math.sqrt(ss / dof), "median_abs_error": float(np.median(d)),
                     "share_within_5pct": float(np.mean(d <= 0.05))}
    weights = {p: (mix or {}).get(p, st["n_rows"] if mix is None else 0) for p, st in per.items()}
    total = sum(weights.values())
    share = (sum(weights[p] * per[p]["share_within_5pct"] for p in per) / total
             if total else None)
    return {"per_procedure": per, "share_within_5pct": share}


def _twin_columns(r: dict[str, Any]) -> dict[str, float] | None:
    if features(r) is None:
        return None
    cols = {k: float(r[k]) for k in ("mass_kg", "n_v_ratio", "axle_ratio", "rated_power_w",
                                     "displacement_l")}
    for mph in (20, 50, 70):
        cols[f"road_load_{mph}"] = max(road_load(r, float(mph)), 1.0)
    return cols


def _is_twin(a: dict[str, float], b: dict[str, float]) -> bool:
    return all(abs(a[k] - b[k]) <= tol if k == "displacement_l" else abs(a[k] / b[k] - 1.0) <= tol
               for k, tol in TWIN_TOLERANCE.items())


def _share(err: list[float]) -> dict[str, Any]:
    a = np.abs(np.asarray(err, float))
    return {"n": len(a), "median_abs_error": float(np.median(a)) if len(a) else None,
            "share_within_5pct": float(np.mean(a <= 0.05)) if len(a) else None}


def twin_check(judged_rows: Sequence[dict[str, Any]], error_key: str,
               fit_lists: dict[str, set[str]]) -> dict[str, Any]:
    """The near twins of the judged rows in their fit lists.

    ``judged_rows``: every judged record (their measured figures are the twins);
    ``error_key``: the fleet model's error key of the rows judged; ``fit_lists``: judged
    list -> the lists its fit was made on. Per procedure: ``twin`` (the twins' geometric
    mean measured figure as the prediction) and ``model`` on the rows with a twin,
    ``model_without_twin`` on the others; each ``n``, ``median_abs_error`` and
    ``share_within_5pct`` [-]."""
    columns = [(r, _twin_columns(r)) for r in judged_rows]  # once per row
    pool: dict[tuple, list[tuple[dict[str, Any], dict[str, float]]]] = defaultdict(list)
    for r, cols in columns:
        if cols is not None and r.get("measured_mpg"):
            pool[(r["list"], make_key(r), *(r.get(k) for k in _TWIN_SAME))].append((r, cols))
    twin_err: dict[str, list[float]] = defaultdict(list)
    model_err: dict[str, list[float]] = defaultdict(list)
    alone_err: dict[str, list[float]] = defaultdict(list)
    for r, cols in columns:
        err = r.get(error_key)
        if err is None or r.get("in_sample") or cols is None:
            continue
        same = (make_key(r), *(r.get(k) for k in _TWIN_SAME))
        logs = [math.log(t["measured_mpg"]) for lst in sorted(fit_lists.get(r["list"], ()))
                for t, c in pool.get((lst, *same), ())
                if t.get("vehicle_id") != r.get("vehicle_id") and _is_twin(cols, c)]
        if logs:
            twin_err[r["procedure"]].append(math.exp(float(np.mean(logs))) / r["measured_mpg"] - 1)
            model_err[r["procedure"]].append(err)
        else:
            alone_err[r["procedure"]].append(err)
    return {p: {"twin": _share(twin_err[p]), "model": _share(model_err[p]),
                "model_without_twin": _share(alone_err[p])}
            for p in sorted({*twin_err, *alone_err})}
