"""The regression baselines of the fleet and the physics model's learned residual.

What a physics model from specifications must beat: log(fuel economy) fitted, per procedure,
on the list's own columns of the same rows (:func:`features`: log test weight, the road-load
force at 20, 50 and 70 mph, log displacement, log rated power, power per weight, cylinders,
N/V, axle ratio, gears, one-hot transmission class, fuel and aspiration), by two learners:

* the **ridge** baseline: a log-linear fit on those columns, standardised, with an L2
  penalty whose weight is chosen on the training rows by generalised cross-validation;
* the **boosted** baseline: gradient-boosted trees (scikit-learn's histogram gradient
  boosting) on the same columns and the make (categorical): the strongest regression on the
  list's columns we know, non-linear, and told the manufacturer. The trees are fitted with
  the squared and with the absolute error, and the loss is chosen per list and procedure on
  that list's own within-year folds (year to year: the choice of the list fitted on).

The **physics + learned residual** (the fleet model, reported beside the physics model):
the same boosted trees fitted to the physics model's log error log(predicted / measured)
and divided out of its prediction. Each is judged like the model:

* **within a year**: 10-fold cross-validation over the rows of one list, the folds drawn by
  test vehicle (a car's tests are never split between fitting and judging);
* **year to year** (two lists or more): fitted on one list's rows, judged on another's. The
  residual is fitted on the rows of the list the judged row's technology coefficients were
  fitted on, simulated with those coefficients (its in-sample rows: the ``training``
  records), so that it learns what those coefficients miss, not another fit's level.
"""

from __future__ import annotations

import math
from collections import defaultdict
from functools import partial
from typing import Any, Callable, Sequence

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
#: the record keys of the boosted baseline (within a year, year to year: mpg and error)
BOOSTED_KEYS = ("boosted_mpg", "boosted_error", "boosted_year_mpg", "boosted_year_error")
#: the record keys of the physics + learned residual (reported beside the physics model)
RESIDUAL_KEYS = ("residual_mpg", "residual_error", "residual_year_mpg", "residual_year_error")
#: the fleet model's verdict keys: its expanded uncertainty (k = 2) [mpg] and En
RESIDUAL_VERDICT_KEYS = ("residual_u_model_mpg", "residual_en")
#: the boosted trees' settings (chosen on the within-year folds of the 2016 and 2019 lists;
#: the year-to-year figures move by under 0.2 point over learning rates 0.03-0.1)
#: least training rows over a batch of fits to run them in processes (below it, here)
PARALLEL_MIN_ROWS = 20000
#: the losses the boosted trees are fitted with, chosen per list and procedure on the list's
#: own within-year folds (the squared error follows the mean, the absolute error the median:
#: a few rows 10-20 % off pull the first)
LOSSES = ("squared_error", "absolute_error")
BOOST = {"learning_rate": 0.05, "max_iter": 300, "max_leaf_nodes": 15, "min_samples_leaf": 10,
         "l2_regularization": 1.0, "random_state": 0}


def road_load(r: dict[str, Any], mph: float) -> float:
    """The row's target road load at ``mph`` [N]."""
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
    f_lo, f_mid, f_hi = (max(road_load(r, v), 1.0) for v in (20.0, 50.0, 70.0))
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


Item = tuple[dict[str, Any], list[float]]
Learner = Callable[[np.ndarray, np.ndarray], Callable[[np.ndarray], np.ndarray]]


def make_key(r: dict[str, Any]) -> str:
    """The row's make, spelled one way (the lists write ``KIA`` and ``Kia``)."""
    return str(r.get("make") or "").strip().upper()


def _usable(records: Sequence[dict[str, Any]],
            makes: dict[str, int]) -> list[Item]:
    """Judged rows with every column: (record, :func:`features` + the make's code)."""
    out = []
    for r in records:
        if r.get("status") != "run" or not r.get("judged") or not r.get("measured_mpg"):
            continue
        x = features(r)
        if x is not None:
            out.append((r, x + [float(makes.get(make_key(r), math.nan))]))
    return out


def ridge(x: np.ndarray, y: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The ridge learner on the numeric columns (the make, the last column, left out)."""
    model = fit_ridge(x[:, :-1], y)
    return lambda z: predict_ridge(model, z[:, :-1])


def boosted(x: np.ndarray, y: np.ndarray, loss: str = "squared_error",
            settings: dict[str, Any] | None = None) -> Callable[[np.ndarray], np.ndarray]:
    """Gradient-boosted trees on every column, the make (the last column) categorical,
    fitted with ``loss`` (one of :data:`LOSSES`) and ``settings`` (default :data:`BOOST`)."""
    from sklearn.ensemble import HistGradientBoostingRegressor

    mask = [False] * (x.shape[1] - 1) + [True]
    model = HistGradientBoostingRegressor(categorical_features=mask, loss=loss,
                                          **(BOOST if settings is None else settings)).fit(x, y)
    return model.predict


def boosted_learners() -> dict[str, Learner]:
    """The boosted trees with each of :data:`LOSSES` (name -> learner), each carrying the
    settings of :data:`BOOST` as they are now (a fit in another process gets the same)."""
    return {loss: partial(boosted, loss=loss, settings=dict(BOOST)) for loss in LOSSES}


def _folds(rows: list[dict[str, Any]], n: int = N_FOLDS) -> list[int]:
    """Fold of each row, drawn by test vehicle (deterministic: sorted vehicle ids dealt out)."""
    vids = sorted({r["vehicle_id"] for r in rows})
    fold = {v: k % n for k, v in enumerate(vids)}
    return [fold[r["vehicle_id"]] for r in rows]


class _Fits:
    """Fits gathered to run together, each a learner fitted on training rows that predicts
    other rows (its predictions written into those rows by :func:`_put`); in ``jobs``
    processes (joblib) when their training rows add up to :data:`PARALLEL_MIN_ROWS`, else
    here. The trees use one core for a fit this size (their threads give under 5 %)."""

    def __init__(self, jobs: int = 1) -> None:
        self.jobs = jobs
        self.tasks: list[tuple[Learner, np.ndarray, np.ndarray, np.ndarray]] = []
        self.dest: list[tuple[list[dict[str, Any]], tuple[str, str], Any]] = []

    def add(self, learner: Learner, items: list[Item], target: Any,
            judged: list[Item], keys: tuple[str, str], to_mpg: Any) -> None:
        self.tasks.append((learner, np.array([f for _, f in items]),
                           np.array([target(r) for r, _ in items]),
                           np.array([f for _, f in judged])))
        self.dest.append(([r for r, _ in judged], keys, to_mpg))

    def run(self) -> None:
        if self.jobs > 1 and sum(len(t[2]) for t in self.tasks) >= PARALLEL_MIN_ROWS:
            from joblib import Parallel, delayed

            preds = Parallel(n_jobs=self.jobs)(delayed(_fit_and_predict)(*t)
                                               for t in self.tasks)
        else:
            preds = [_fit_and_predict(*t) for t in self.tasks]
        for (rows, keys, to_mpg), pred in zip(self.dest, preds):
            _put(rows, pred, keys, to_mpg)
        self.tasks, self.dest = [], []


def _fit_and_predict(learner: Learner, x: np.ndarray, y: np.ndarray,
                     x_judged: np.ndarray) -> np.ndarray:
    return learner(x, y)(x_judged)


def _put(rows: list[dict[str, Any]], pred: np.ndarray, keys: tuple[str, str],
         to_mpg: Any) -> None:
    for r, p in zip(rows, pred):
        mpg = float(to_mpg(r, p))
        r[keys[0]], r[keys[1]] = mpg, mpg / r["measured_mpg"] - 1.0


def _within_year(groups: dict[tuple[str, str], list[Item]], target: Any,
                 keys: tuple[str, str], to_mpg: Any, learner: Learner, fits: _Fits) -> None:
    """10-fold cross-validated predictions of ``target(record)`` by ``learner`` within each
    list, the folds drawn by test vehicle, added to ``fits`` to be written as ``keys[0]``
    (mpg) / ``keys[1]`` (error); ``to_mpg(record, prediction)`` turns a prediction into
    fuel economy [mpg]."""
    for items in groups.values():
        if len(items) < MIN_ROWS:
            continue
        folds = np.array(_folds([r for r, _ in items]))
        for k in range(N_FOLDS):
            test = folds == k
            if not test.any() or (~test).sum() < MIN_ROWS:
                continue
            fits.add(learner, [it for it, t in zip(items, test) if not t], target,
                     [it for it, t in zip(items, test) if t], keys, to_mpg)


def _year_to_year(groups: dict[tuple[str, str], list[Item]], target: Any,
                  keys: tuple[str, str], to_mpg: Any,
                  learner_for: Callable[[str, set[str]], Learner], fits: _Fits,
                  train: dict[tuple[str, str], list[Item]] | None = None) -> None:
    """Predictions fitted on the other lists, added to ``fits`` to be written as
    ``keys[0]`` / ``keys[1]``; ``learner_for(procedure, fit lists)`` gives the learner.

    ``train``: the rows to fit on, split by technology coefficients: a row is judged by a
    fit on the other lists' rows built with its own coefficients (default: by a fit on the
    other lists' rows of ``groups``, whatever their coefficients)."""
    pool = groups if train is None else train
    if len({lst for lst, _ in groups}) < 2:
        return
    for (lst, proc), items in groups.items():
        by_coef: dict[Any, list[Item]] = defaultdict(list)
        for it in items:
            by_coef[it[0].get("coefficients") if train is not None else None].append(it)
        for coef, judged in by_coef.items():
            fit_rows = [it for (l2, p2), its in pool.items() if p2 == proc and l2 != lst
                        for it in its if train is None or it[0].get("coefficients") == coef]
            if len(fit_rows) < MIN_ROWS:
                continue
            fits.add(learner_for(proc, {r["list"] for r, _ in fit_rows}), fit_rows, target,
                     judged, keys, to_mpg)


def _fit_predict(groups: dict[tuple[str, str], list[Item]], target: Any,
                 keys: tuple[str, str, str, str], to_mpg: Any, learner: Learner) -> None:
    """:func:`_within_year` as ``keys[:2]`` and :func:`_year_to_year` as ``keys[2:]``, one
    learner (:func:`_fit_predict_chosen` with nothing to choose)."""
    _fit_predict_chosen(groups, target, keys, to_mpg, {"only": learner})


def _fit_predict_chosen(groups: dict[tuple[str, str], list[Item]], target: Any,
                        keys: tuple[str, str, str, str], to_mpg: Any,
                        learners: dict[str, Learner],
                        train: dict[tuple[str, str], list[Item]] | None = None,
                        jobs: int = 1) -> dict[str, dict[str, dict[str, str]]]:
    """:func:`_fit_predict` with the learner chosen among ``learners`` (name -> learner) per
    list and procedure on that list's own within-year folds (the smallest median |error|
    over its rows out of the technology coefficients' fit, or all its rows when none is);
    year to year, the fit takes the learner chosen on the
    lists it is fitted on (their within-year rows pooled), never on the judged list.
    Returns scheme -> procedure -> list (within a year) or the fit lists joined by `` + ``
    (year to year) -> the name chosen."""
    fits = _Fits(jobs)
    tmp = {name: (f"_{name}_mpg", f"_{name}_error") for name in learners}
    for name, learner in learners.items():
        _within_year(groups, target, tmp[name], to_mpg, learner, fits)
    fits.run()
    # judged on the rows out of the technology coefficients' fit (a test carried over from
    # the list fitted on is that list's, not this one's); a list judged with its own fit
    # has none: all its rows
    out = {g: [it for it in items if not it[0].get("in_sample")] or items
           for g, items in groups.items()}
    trial = {name: {g: [r[k[1]] for r, _ in items if k[1] in r]
                    for g, items in out.items()} for name, k in tmp.items()}

    def best(errs: dict[str, list[float]]) -> str:
        scored = [(float(np.median(np.abs(e))), n) for n, e in errs.items() if e]
        return min(scored)[1] if scored else next(iter(learners))

    chosen = {g: best({n: trial[n][g] for n in learners}) for g in groups}
    for g, items in groups.items():  # the chosen learner's within-year predictions
        for r, _ in items:
            k = tmp[chosen[g]]
            if k[1] in r:
                r[keys[0]], r[keys[1]] = r[k[0]], r[k[1]]
            for k in tmp.values():
                r.pop(k[0], None)
                r.pop(k[1], None)

    year: dict[str, dict[str, str]] = defaultdict(dict)

    def learner_for(proc: str, lists: set[str]) -> Learner:
        name = best({n: [e for g, es in trial[n].items() if g[1] == proc and g[0] in lists
                         for e in es] for n in learners})
        year[proc][" + ".join(sorted(lists))] = name
        return learners[name]

    _year_to_year(groups, target, keys[2:], to_mpg, learner_for, fits, train)
    fits.run()
    within: dict[str, dict[str, str]] = defaultdict(dict)
    for (lst, proc), name in chosen.items():
        within[proc][lst] = name
    return {"within_year": dict(within), "year_to_year": dict(year)}


def cross_validate(records: Sequence[dict[str, Any]],
                   training: Sequence[dict[str, Any]] = (), jobs: int = 1) -> dict[str, Any]:
    """The baselines' cross-validated predictions, written into the records (ridge:
    ``baseline_mpg`` / ``baseline_error`` within a year, ``baseline_year_mpg`` /
    ``baseline_year_error`` fitted on the other lists; boosted: ``boosted_*``), the physics
    + learned residual (``residual_*``), and the comparison per procedure and scheme.

    ``training``: rows simulated only to fit the residual year to year (a list's rows built
    with the coefficients fitted on it; see the module's docstring); never judged.
    ``jobs``: processes for the trees' fits (the results do not depend on it)."""
    every = [*records, *training]
    makes = {m: k for k, m in enumerate(sorted({make_key(r) for r in every}))}
    groups: dict[tuple[str, str], list[Item]] = defaultdict(list)
    for r, x in _usable(records, makes):
        groups[(r["list"], r["procedure"])].append((r, x))
    def log_mpg(r: dict[str, Any]) -> float:
        return math.log(r["measured_mpg"])

    def mpg(r: dict[str, Any], p: float) -> float:
        return math.exp(p)

    _fit_predict(groups, log_mpg, BASELINE_KEYS, mpg, ridge)
    losses = {"boosted": _fit_predict_chosen(groups, log_mpg, BOOSTED_KEYS, mpg,
                                             boosted_learners(), jobs=jobs)}

    def physics(items: list[Item]) -> dict[tuple[str, str], list[Item]]:
        out: dict[tuple[str, str], list[Item]] = defaultdict(list)
        for r, x in items:
            if (r.get("predicted_mpg") or 0) > 0:
                out[(r["list"], r["procedure"])].append((r, x))
        return out

    losses["physics_residual"] = _fit_predict_chosen(
        physics([it for its in groups.values() for it in its]),
        lambda r: math.log(r["predicted_mpg"] / r["measured_mpg"]), RESIDUAL_KEYS,
        lambda r, p: r["predicted_mpg"] / math.exp(p), boosted_learners(),
        train=physics(_usable(every, makes)), jobs=jobs)
    residual_verdicts(records)
    out = compare(records)
    for scheme, procs in out.items():
        for proc, d in procs.items():
            d["loss"] = {learner: by[scheme].get(proc, {}) for learner, by in losses.items()}
    return out


def residual_verdicts(records: Sequence[dict[str, Any]]) -> None:
    """The fleet model's normalised error year to year, written into the records
    (:data:`RESIDUAL_VERDICT_KEYS`): En = (residual_year_mpg - measured) / sqrt(U_model^2 +
    U_meas^2), U_meas the row's (``u_meas_mpg``, the lists' reproducibility), U_model = 2 x
    u x prediction with u the model's own scatter: the robust standard deviation (1.4826 x
    MAD) of the fleet model's within-year cross-validated log errors on the *other* lists'
    out-of-sample rows of the procedure, less the lists' measurement part in quadrature. No
    verdict with one list (its own scatter would judge it)."""
    from vehval.uncertainty import normalised_error

    by: dict[tuple[str, str], list[float]] = defaultdict(list)
    meas: dict[str, list[float]] = defaultdict(list)
    for r in records:
        if (r.get("residual_error") is not None and not r.get("in_sample")
                and r.get("u_meas_mpg")):
            by[(r["list"], r["procedure"])].append(math.log1p(r["residual_error"]))
            meas[r["procedure"]].append(r["u_meas_mpg"] / 2.0 / r["measured_mpg"])

    def model_u_rel(lst: str, proc: str) -> float | None:
        """u of the fleet model judging ``lst`` on ``proc`` [-] (None: too few rows)."""
        others = [e for (l2, p2), es in by.items() if p2 == proc and l2 != lst for e in es]
        if len(others) < MIN_ROWS:
            return None
        a = np.array(others)
        sigma = 1.4826 * float(np.median(np.abs(a - np.median(a))))
        return math.sqrt(max(sigma ** 2 - float(np.median(meas[proc])) ** 2, 0.0))

    u_of: dict[tuple[str, str], float | None] = {}
    for r in records:
        pred, u_meas = r.get("residual_year_mpg"), r.get("u_meas_mpg")
        if pred is None or not u_meas:
            continue
        key = (r["list"], r["procedure"])
        if key not in u_of:  # once per list and procedure
            u_of[key] = model_u_rel(*key)
        u_rel = u_of[key]
        if u_rel is None:
            continue
        u_model = 2.0 * u_rel * pred
        r["residual_u_model_mpg"] = u_model
        r["residual_en"] = normalised_error(pred, r["measured_mpg"], u_model, u_meas).en


def _stats(err: list[float]) -> dict[str, Any]:
    a = np.abs(np.array(err))
    return {"n": len(err), "median_abs_error": float(np.median(a)) if len(a) else None,
            "mean_error": float(np.mean(err)) if len(err) else None,
            "share_within_5pct": float(np.mean(a <= 0.05)) if len(a) else None}


def compare(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per procedure and scheme (``within_year``, ``year_to_year``), on the same rows (those
    out of the technology coefficients' fit: a row marked ``in_sample`` is left out): the
    physics model's (``model``), the ridge baseline's (``baseline``), the boosted baseline's
    (``boosted``) and the physics + learned residual's (``physics_residual``) errors;
    ``model_better``: physics has the smaller median |error| than the ridge;
    ``residual_better``: physics + learned residual has a smaller one than both baselines."""
    out: dict[str, Any] = {}
    for scheme, key, boost_key, res_key in (
            ("within_year", "baseline_error", "boosted_error", "residual_error"),
            ("year_to_year", "baseline_year_error", "boosted_year_error",
             "residual_year_error")):
        per: dict[str, dict[str, list[float]]] = defaultdict(
            lambda: {"model": [], "base": [], "boost": [], "res": []})
        for r in records:  # out-of-sample rows only: the physics model's fit never saw them
            if r.get(key) is None or r.get("error") is None or r.get("in_sample"):
                continue
            d = per[r["procedure"]]
            d["model"].append(r["error"])
            d["base"].append(r[key])
            if r.get(boost_key) is not None:
                d["boost"].append(r[boost_key])
            if r.get(res_key) is not None:
                d["res"].append(r[res_key])
        if not per:
            continue
        out[scheme] = {}
        for proc, d in sorted(per.items()):
            m, b = _stats(d["model"]), _stats(d["base"])
            bo, res = _stats(d["boost"]), _stats(d["res"])
            best_base = min(x for x in (b["median_abs_error"], bo["median_abs_error"])
                            if x is not None)
            out[scheme][proc] = {
                "model": m, "baseline": b, "boosted": bo, "physics_residual": res,
                "model_better": m["median_abs_error"] < b["median_abs_error"],
                "residual_better": (res["median_abs_error"] is not None
                                    and res["median_abs_error"] < best_base)}
    return out
