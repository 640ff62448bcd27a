"""The regression baseline of the fleet: a ridge log-linear fit on the list's own columns.

What a physics model from specifications must beat: log(fuel economy) fitted, per procedure,
as a linear function of about 20 columns of the same rows (:func:`features`: log test
weight, the road-load force at 20, 50 and 70 mph, log displacement, log rated power, power
per weight, cylinders, N/V, axle ratio, gears, one-hot transmission class, fuel and
aspiration), standardised, with an L2 penalty (ridge) whose weight is chosen on the training
rows by generalised cross-validation. It is judged like the model:

* **within a year**: 10-fold cross-validation over the rows of one list, the folds drawn by
  test vehicle (a car's tests are never split between fitting and judging);
* **year to year** (two lists or more): fitted on one list's rows, judged on another's.

The same ridge fitted to the physics model's log error and divided out of its prediction
is the **physics + regression residual**, cross-validated the same way and reported apart
from the physics model (:func:`cross_validate`).

numpy only: the fit is a linear solve of a 20 x 20 system.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any, Sequence

import numpy as np

from vehval.constants import MPH_M_PER_S

#: folds of the within-year cross-validation
N_FOLDS = 10
#: ridge weights tried (on standardised columns; chosen by generalised cross-validation)
LAMBDAS = (1e-3, 1e-2, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0)
#: the categorical columns and their levels (one-hot; the first level is the reference)
CATEGORIES = {
    "transmission_class": ("automatic", "CVT", "dual-clutch", "manual", "other"),
    "fuel_family": ("gasoline", "diesel", "e85"),
    "aspiration": ("naturally aspirated", "turbocharged", "diesel", "unknown"),
}
#: least rows of a procedure to fit (below it the baseline is not stated)
MIN_ROWS = 12
#: the record keys of the baseline (within a year, year to year: mpg and error)
BASELINE_KEYS = ("baseline_mpg", "baseline_error", "baseline_year_mpg", "baseline_year_error")
#: the record keys of the physics + regression residual (reported apart from the physics)
RESIDUAL_KEYS = ("residual_mpg", "residual_error", "residual_year_mpg", "residual_year_error")


def _road_load(r: dict[str, Any], mph: float) -> float:
    v = mph * MPH_M_PER_S
    return r["target_a_n"] + r["target_b_n_per_mps"] * v + r["target_c_n_per_mps2"] * v * v


def features(r: dict[str, Any]) -> list[float] | None:
    """The numeric columns of one row record (None: a column the fit needs is missing)."""
    need = ("mass_kg", "displacement_l", "rated_power_w", "n_v_ratio", "axle_ratio",
            "target_a_n", "target_b_n_per_mps", "target_c_n_per_mps2")
    if any(r.get(k) is None or not r[k] > -1e9 for k in need):
        return None
    if not (r["mass_kg"] > 0 and r["displacement_l"] > 0 and r["rated_power_w"] > 0):
        return None
    f_lo, f_mid, f_hi = (max(_road_load(r, v), 1.0) for v in (20.0, 50.0, 70.0))
    x = [math.log(r["mass_kg"]), math.log(f_lo), math.log(f_mid), math.log(f_hi),
         math.log(r["displacement_l"]), math.log(r["rated_power_w"]),
         math.log(r["rated_power_w"] / r["mass_kg"]), float(r.get("cylinders") or 0),
         float(r["n_v_ratio"]), float(r["axle_ratio"]), float(r.get("gears") or 0)]
    for key, levels in CATEGORIES.items():
        x += [1.0 if r.get(key) == lev else 0.0 for lev in levels[1:]]
    return x


def fit_ridge(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Ridge fit of ``y`` on standardised ``x``: (coefficients, column means, column scales,
    lambda), lambda chosen by generalised cross-validation among :data:`LAMBDAS`."""
    mu = x.mean(axis=0)
    sd = x.std(axis=0)
    sd[sd == 0] = 1.0
    z = (x - mu) / sd
    y0 = y.mean()
    u, s, vt = np.linalg.svd(z, full_matrices=False)
    uty = u.T @ (y - y0)
    n = len(y)
    best = (math.inf, LAMBDAS[0], np.zeros(z.shape[1]))
    for lam in LAMBDAS:
        d = s / (s ** 2 + lam)
        beta = vt.T @ (d * uty)
        resid = y - y0 - z @ beta
        dof = float(np.sum(s ** 2 / (s ** 2 + lam)))
        gcv = float(resid @ resid) / n / max(1.0 - dof / n, 1e-6) ** 2
        if gcv < best[0]:
            best = (gcv, lam, beta)
    coef = np.r_[y0, best[2]]
    return coef, mu, sd, best[1]


def predict_ridge(model: tuple, x: np.ndarray) -> np.ndarray:
    """log-fuel-economy predictions of a :func:`fit_ridge` model."""
    coef, mu, sd, _ = model
    return coef[0] + ((x - mu) / sd) @ coef[1:]


def _usable(records: Sequence[dict[str, Any]]) -> list[tuple[dict[str, Any], list[float]]]:
    out = []
    for r in records:
        if r.get("status") != "run" or not r.get("judged") or not r.get("measured_mpg"):
            continue
        x = features(r)
        if x is not None:
            out.append((r, x))
    return out


def _folds(rows: list[dict[str, Any]], n: int = N_FOLDS) -> list[int]:
    """Fold of each row, drawn by test vehicle (deterministic: sorted vehicle ids dealt out)."""
    vids = sorted({r["vehicle_id"] for r in rows})
    fold = {v: k % n for k, v in enumerate(vids)}
    return [fold[r["vehicle_id"]] for r in rows]


def _fit_predict(groups: dict[tuple[str, str], list[tuple[dict[str, Any], list[float]]]],
                 target: Any, keys: tuple[str, str, str, str], to_mpg: Any) -> None:
    """Cross-validated ridge predictions of ``target(record)`` written into the records:
    10-fold by test vehicle within a list as ``keys[0]`` (mpg) / ``keys[1]`` (error), and
    fitted on the other lists as ``keys[2]`` / ``keys[3]``; ``to_mpg(record, prediction)``
    turns a prediction into fuel economy [mpg]."""

    def put(rows: list[dict[str, Any]], pred: np.ndarray, k_mpg: str, k_err: str) -> None:
        for r, p in zip(rows, pred):
            mpg = float(to_mpg(r, p))
            r[k_mpg], r[k_err] = mpg, mpg / r["measured_mpg"] - 1.0

    for items in groups.values():
        if len(items) < MIN_ROWS:
            continue
        rows = [r for r, _ in items]
        xa = np.array([f for _, f in items])
        y = np.array([target(r) for r in rows])
        folds = np.array(_folds(rows))
        for k in range(N_FOLDS):
            test = folds == k
            if not test.any() or (~test).sum() < MIN_ROWS:
                continue
            put([r for r, t in zip(rows, test) if t],
                predict_ridge(fit_ridge(xa[~test], y[~test]), xa[test]), keys[0], keys[1])
    if len({lst for lst, _ in groups}) < 2:
        return
    for (lst, proc), items in groups.items():
        train = [it for (l2, p2), its in groups.items() if p2 == proc and l2 != lst
                 for it in its]
        if len(train) < MIN_ROWS:
            continue
        model = fit_ridge(np.array([f for _, f in train]),
                          np.array([target(r) for r, _ in train]))
        put([r for r, _ in items], predict_ridge(model, np.array([f for _, f in items])),
            keys[2], keys[3])


def cross_validate(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The baseline's cross-validated predictions, written into the records as
    ``baseline_mpg`` / ``baseline_error`` (within a year; ``baseline_year_mpg`` /
    ``baseline_year_error`` fitted on the other lists), and the comparison with the model
    per procedure and scheme.

    Beside it, and reported apart (never as the physics model): **physics + regression
    residual**, the same ridge on the same columns fitted to the physics model's log error
    log(predicted / measured) and divided out of its prediction, cross-validated the same
    way (``residual_mpg`` / ``residual_error``, ``residual_year_mpg`` /
    ``residual_year_error``)."""
    usable = _usable(records)
    groups: dict[tuple[str, str], list[tuple[dict[str, Any], list[float]]]] = defaultdict(list)
    for r, x in usable:
        groups[(r["list"], r["procedure"])].append((r, x))
    _fit_predict(groups, lambda r: math.log(r["measured_mpg"]), BASELINE_KEYS,
                 lambda r, p: math.exp(p))
    phys = {g: [(r, x) for r, x in its if (r.get("predicted_mpg") or 0) > 0]
            for g, its in groups.items()}
    _fit_predict(phys, lambda r: math.log(r["predicted_mpg"] / r["measured_mpg"]),
                 RESIDUAL_KEYS, lambda r, p: r["predicted_mpg"] / math.exp(p))
    return compare(records)


def _stats(err: list[float]) -> dict[str, Any]:
    a = np.abs(np.array(err))
    return {"n": len(err), "median_abs_error": float(np.median(a)) if len(a) else None,
            "mean_error": float(np.mean(err)) if len(err) else None,
            "share_within_5pct": float(np.mean(a <= 0.05)) if len(a) else None}


def compare(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per procedure and scheme (``within_year``, ``year_to_year``): the model's and the
    baseline's errors on the same rows (those out of the technology coefficients' fit: a row
    marked ``in_sample`` is left out of both), and whether the model is better (smaller median
    |error|); ``physics_residual``: the physics + regression residual on its rows (apart:
    it is not the physics model)."""
    out: dict[str, Any] = {}
    for scheme, key, res_key in (("within_year", "baseline_error", "residual_error"),
                                 ("year_to_year", "baseline_year_error",
                                  "residual_year_error")):
        per: dict[str, dict[str, list[float]]] = defaultdict(
            lambda: {"model": [], "base": [], "res": []})
        for r in records:  # out-of-sample rows only: the physics model's fit never saw them
            if r.get(key) is None or r.get("error") is None or r.get("in_sample"):
                continue
            per[r["procedure"]]["model"].append(r["error"])
            per[r["procedure"]]["base"].append(r[key])
            if r.get(res_key) is not None:
                per[r["procedure"]]["res"].append(r[res_key])
        if not per:
            continue
        out[scheme] = {}
        for proc, d in sorted(per.items()):
            m, b = _stats(d["model"]), _stats(d["base"])
            out[scheme][proc] = {"model": m, "baseline": b,
                                 "model_better": m["median_abs_error"] < b["median_abs_error"],
                                 "physics_residual": _stats(d["res"])}
    return out
