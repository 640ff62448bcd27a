"""Calibration: tune named vehicle parameters so the simulation matches several tests.

``calibrate(tests, vehicle, parameters=[...])`` minimises the weighted error of
:mod:`vehval.validate.objective` (fuel, SOC, engine state, component NRMSE) averaged over
the tests, then reports the error before and after on the tuned and on held-out tests.

Evaluation. By default (``mode='traces'``) every candidate is simulated with recording and
scored on the full objective (step-wise engine state and component NRMSE): with controller
and component parameters tuned together, the end-of-test quantities alone (fuel, SOC,
engine-on share, starts) leave a flat valley of equally good combinations, the signals
(battery current, engine torque) pin it. ``mode='batch'`` evaluates each generation with
one call of :func:`vehval.sim.batch.simulate_batch` per tuning test (summaries only,
parallel compiled loop): faster, enough for a few controller parameters.

Search. The objective is piecewise constant in thresholds and hold times (an engine start
moves by whole time steps) and has many shallow local minima, so gradients are useless. We
use a population method: differential evolution followed by a bounded Nelder-Mead polish
(:func:`vehval.calibration.de_polish`, the package's calibration engine, which also gives
the hold-out evaluation and the provenance written into the vehicle file). The polish is
kept only if it improves the objective. Every candidate is a validated copy of the vehicle;
an invalid combination (e.g. engine-off speed above engine-on speed) gets a penalty.
"""

from __future__ import annotations

import datetime as _dt
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from vehval.calibration import (
    HOLDOUT_TOL_POINTS,
    Provenance,
    before_after,
    de_polish,
    holdout_worse,
    vehicle_with_values,
    write_vehicle_yaml,
)
from vehval.calibration.provenance import bounds_text, calibration_tests, same_test
from vehval.errors import ConfigError
from vehval.jsonsafe import clean
from vehval.sim.simulate import simulate
from vehval.test import Test
from vehval.uncertainty import InsufficientDataError, normalised_error, set_verdict
from vehval.validate.conditions import full_name as _full_name
from vehval.validate.conditions import vehicle_variant as variant
from vehval.validate.ladder import LadderEntry, errors_of, judge_fuel
from vehval.validate.objective import (
    DEFAULT_SIGNALS,
    Target,
    errors,
    errors_from_summary,
    make_target,
    objective,
)
from vehval.validate.validation import validate_test
from vehval.vehicle import BLOCKS, Vehicle, load_vehicle

__all__ = ["HOLDOUT_TOL_POINTS", "MODES", "PENALTY", "CalibrationResult", "calibrate",
           "check_start", "default_bounds", "holdout_worse", "start_limits", "start_values",
           "vehicle_with_values", "write_vehicle_yaml"]

PENALTY = 1e6  # objective of an invalid parameter combination
MODES = ("traces", "batch")


def _value_of(vehicle: Vehicle, name: str) -> float:
    blk, key = name.split(".", 1)
    if blk not in BLOCKS or not hasattr(getattr(vehicle, blk), key) or key == "sources":
        raise ConfigError(f"calibration parameter '{name}': unknown (use <block>.<parameter>, "
                          f"block one of {', '.join(BLOCKS)}; bare names mean controller.<name>)")
    val = getattr(getattr(vehicle, blk), key)
    if not isinstance(val, (int, float)) or isinstance(val, bool):
        raise ConfigError(f"calibration parameter '{name}' is not a scalar (maps cannot be tuned)")
    return float(val)


def _field_limits(vehicle: Vehicle, name: str) -> tuple[float, float]:
    """Open/closed limits of a parameter from its pydantic constraints (gt/ge/lt/le)."""
    blk, key = name.split(".", 1)
    lo, hi = -math.inf, math.inf
    for m in type(getattr(vehicle, blk)).model_fields[key].metadata:
        if getattr(m, "ge", None) is not None:
            lo = max(lo, float(m.ge))
        if getattr(m, "gt", None) is not None:
            lo = max(lo, float(m.gt) + 1e-9 * max(1.0, abs(float(m.gt))))
        if getattr(m, "le", None) is not None:
            hi = min(hi, float(m.le))
        if getattr(m, "lt", None) is not None:
            hi = min(hi, float(m.lt) - 1e-9 * max(1.0, abs(float(m.lt))))
    return lo, hi


def default_bounds(vehicle: Vehicle, name: str, start: float, rel: float = 0.5) -> tuple[float, float]:
    """``start · (1 ± rel)`` (``±1`` around zero), clipped to the parameter's constraints."""
    span = abs(start) * rel if start != 0 else 1.0
    lo, hi = _field_limits(vehicle, name)
    return max(start - span, lo), min(start + span, hi)


#: A given start value lies within this factor of the vehicle's own value in magnitude: a
#: start refines the model of this car (1e300 W is no controller threshold of any car)
START_FACTOR = 10.0
#: [SI] largest magnitude of a start when the vehicle's value is 0
START_MAX_ABS = 1e9


def start_limits(vehicle: Vehicle, name: str) -> tuple[float, float]:
    """Closed range a given start value of parameter ``name`` must lie in: the parameter's
    own constraints (the vehicle model's), within ``START_FACTOR`` x the magnitude of the
    vehicle's value (``START_MAX_ABS`` when that value is 0)."""
    cap = START_FACTOR * abs(_value_of(vehicle, name)) or START_MAX_ABS
    lo, hi = _field_limits(vehicle, name)
    return max(lo, -cap), min(hi, cap)


def check_start(vehicle: Vehicle, given: dict[str, float], names: Sequence[str]) -> None:
    """Refuse, naming the parameter and its range, a given start value of a tuned parameter
    outside :func:`start_limits` (a start is written into the calibrated vehicle when the
    search finds nothing better)."""
    for n in names:
        if n not in given:
            continue
        lo, hi = start_limits(vehicle, n)
        if not lo <= given[n] <= hi:
            raise ConfigError(f"calibration start of '{n}' {given[n]:.6g} is outside its "
                              f"bounds {lo:.6g} to {hi:.6g} (the model's limits, within "
                              f"{START_FACTOR:g} x the vehicle's value): give a start inside")


def start_values(start: Any, names: Sequence[str] = ()) -> dict[str, float]:
    """Start values from a dict (dotted or controller keys) or an analysis result.

    An analysis result is anything with ``to_dict()`` (or a dict) holding a ``controller``
    mapping of estimated controller parameters in vehicle-file keys. A number that is not
    finite (NaN, Infinity) is refused naming its key, and so is any other value (text) of a
    parameter in ``names`` (dotted: the tuned ones); other text entries (notes) and ``null``
    are not start values.
    """
    if start is None:
        return {}
    if hasattr(start, "to_dict"):
        start = start.to_dict()
    if not isinstance(start, dict):
        raise ConfigError("calibration start must be a dict of parameter values or an analysis result")
    src = start["controller"] if isinstance(start.get("controller"), dict) else start
    out = {}
    for k, v in src.items():
        if isinstance(v, dict) and "value" in v:  # {"value": x, ...} entries
            v = v["value"]
        number = isinstance(v, (int, float)) and not isinstance(v, bool)
        if v is None or not (number or _full_name(k) in names):
            continue
        if not number or not math.isfinite(v):
            raise ConfigError(f"calibration start of '{k}': {v!r} is not a finite number")
        out[_full_name(k)] = float(v)
    return out


@dataclass
class CalibrationResult:
    """Outcome of :func:`calibrate` (parameter values in SI, by dotted name)."""

    parameters: list[str]
    start: dict[str, float]
    bounds: dict[str, tuple[float, float]]
    best: dict[str, float]
    objective_start: float
    objective_best: float
    tests: list[str]
    holdout: list[str]
    before: dict[str, dict[str, float]]
    after: dict[str, dict[str, float]]
    n_evaluations: int
    n_simulations: int
    elapsed_s: float
    method: str
    dt: float
    vehicle: Vehicle
    date: str = ""
    history: list[float] = field(default_factory=list)
    smooth_hz: float | None = None
    notes: list[str] = field(default_factory=list)
    #: Tuned values the over-fitting guard refused (empty when the tuned values were kept).
    rejected: dict[str, float] = field(default_factory=dict)
    #: Tests the starting vehicle file was already calibrated on -> its parameters tuned there.
    prior: dict[str, list[str]] = field(default_factory=dict)

    def in_sample(self, tid: str) -> bool:
        """A tuning test, or a test the starting vehicle file was calibrated on: its errors
        are a fit, not a prediction."""
        return tid in self.tests or _prior_params(self.prior, tid) is not None

    def _role(self, tid: str) -> str:
        if tid in self.tests:
            return "tuned"
        return ("held out (in-sample: the start vehicle was calibrated on it)"
                if _prior_params(self.prior, tid) is not None else "held out")

    def sample_stats(self, in_sample: bool = False) -> dict[str, Any]:
        """Mean |fuel error| and |SOC error| [%] before and after over the held-out tests
        (``in_sample`` False, the headline) or over the in-sample ones (True)."""
        ids = [t for t in self.tests + self.holdout if self.in_sample(t) == in_sample]

        def mean(errs: dict[str, dict[str, float]], key: str) -> float | None:
            v = [abs(errs[t][key]) for t in ids
                 if t in errs and errs[t].get(key) is not None and math.isfinite(errs[t][key])]
            return float(np.mean(v)) if v else None

        return {"tests": ids, "n_tests": len(ids),
                "fuel_pct_before": mean(self.before, "fuel_pct"),
                "fuel_pct_after": mean(self.after, "fuel_pct"),
                "soc_pct_before": mean(self.before, "soc_pct"),
                "soc_pct_after": mean(self.after, "soc_pct")}

    def provenance(self, name: str) -> str:
        """Source text recorded for a tuned parameter in the calibrated vehicle file
        (:class:`vehval.calibration.Provenance`)."""
        return Provenance(
            by="vehval calibrate", tests=self.tests, objective="objective",
            start_value=self.objective_start, best_value=self.objective_best,
            method=self.method, start=self.start,
            ranges={n: bounds_text(*b) for n, b in self.bounds.items()}, dt=self.dt,
            details=([f"measured speed low-passed at {self.smooth_hz:g} Hz"]
                     if self.smooth_hz else []),
            holdout=self.holdout, date=self.date).text(name)

    def calibrated_vehicle(self) -> Vehicle:
        """The fully validated vehicle with the tuned values and their provenance."""
        return vehicle_with_values(
            self.vehicle, self.best, self.provenance,
            f" [calibrated by vehval on {self.date}: {', '.join(self.parameters)}]")

    def write_vehicle(self, path: str | Path) -> Path:
        """Write the calibrated vehicle YAML atomically; it loads with ``load_vehicle``."""
        return write_vehicle_yaml(self.calibrated_vehicle(), path, "vehval calibrate")

    def holdout_verdict(self) -> tuple[dict[str, Any] | None, str]:
        """Set verdict (:func:`vehval.uncertainty.set_verdict`) of the held-out tests after
        calibration, from their fuel En; (None, reason) with fewer than 3."""
        judged, s_rs = [], []
        for tid in self.holdout:
            a = self.after.get(tid, {})
            if self.in_sample(tid) or a.get("en") is None:
                continue
            judged.append(normalised_error(a["fuel_sim_kg"], a["fuel_test_kg"], 0.0,
                                           a["u_meas_kg"], label=tid))
            s_rs.append(a["s_r"] or 0.0)
        try:
            s_r = math.sqrt(sum(x * x for x in s_rs) / len(s_rs)) if s_rs else 0.0
            return set_verdict(judged, s_r=s_r).to_dict(), ""
        except InsufficientDataError as exc:
            return None, str(exc)

    def rows(self) -> list[list[Any]]:
        """[test, role, fuel err before %, after %, SOC err before %, after %, engine agreement
        before %, after %, sample ("in-sample" or "held-out")]."""
        out = []
        for tid in self.tests + self.holdout:
            b, a = self.before.get(tid, {}), self.after.get(tid, {})
            out.append([tid, self._role(tid),
                        b.get("fuel_pct"), a.get("fuel_pct"), b.get("soc_pct"), a.get("soc_pct"),
                        b.get("engine_on_agreement_pct"), a.get("engine_on_agreement_pct"),
                        "in-sample" if self.in_sample(tid) else "held-out"])
        return out

    def tables(self) -> list[dict]:
        return [
            {"title": "Calibrated parameters",
             "columns": ["parameter", "start", "lower bound", "upper bound", "calibrated", "change [%]"],
             "rows": [[n, self.start[n], self.bounds[n][0], self.bounds[n][1], self.best[n],
                       (self.best[n] - self.start[n]) / abs(self.start[n]) * 100 if self.start[n] else None]
                      for n in self.parameters],
             "note": f"objective {self.objective_start:.4g} -> {self.objective_best:.4g}; "
                     f"{self.n_simulations} simulations in {self.elapsed_s:.1f} s ({self.method})"},
            {"title": "Errors before and after calibration",
             "columns": ["test", "role", "fuel before [%]", "fuel after [%]", "SOC before [%]",
                         "SOC after [%]", "engine agreement before [%]", "engine agreement after [%]",
                         "sample"],
             "rows": self.rows(),
             "note": _sample_note(self.sample_stats(), self.sample_stats(in_sample=True))},
        ]

    def to_dict(self) -> dict[str, Any]:
        return clean({
            "parameters": self.parameters, "start": self.start,
            "bounds": {k: list(v) for k, v in self.bounds.items()}, "best": self.best,
            "objective_start": self.objective_start, "objective_best": self.objective_best,
            "tests": self.tests, "holdout": self.holdout, "before": self.before, "after": self.after,
            "n_evaluations": self.n_evaluations, "n_simulations": self.n_simulations,
            "elapsed_s": self.elapsed_s, "method": self.method, "dt_s": self.dt, "date": self.date,
            "speed_smoothing_hz": self.smooth_hz, "notes": self.notes,
            "rejected": self.rejected,
            "in_sample": {t: self.in_sample(t) for t in self.tests + self.holdout},
            "stats": self.sample_stats(), "stats_in_sample": self.sample_stats(in_sample=True),
            "prior_calibration_tests": self.prior,
            "provenance": {n: self.provenance(n) for n in self.parameters},
            "history": self.history, "tables": self.tables(),
            "set_verdict_holdout": self.holdout_verdict()[0],
            "set_verdict_holdout_note": self.holdout_verdict()[1]})


def _sample_note(held: dict[str, Any], ins: dict[str, Any]) -> str:
    """One line: mean |fuel error| before -> after on held-out tests, in-sample apart."""
    def part(st: dict[str, Any]) -> str:
        b, a = st["fuel_pct_before"], st["fuel_pct_after"]
        if b is None or a is None:
            return f"{st['n_tests']} tests"
        return f"{st['n_tests']} tests, mean |fuel error| {b:.2f} -> {a:.2f} %"

    return f"held-out: {part(held)}; in-sample (a fit, not a prediction): {part(ins)}"


class _Problem:
    """Evaluates candidate parameter vectors on every target (counts simulations)."""

    def __init__(self, vehicle: Vehicle, targets: list[Target], names: list[str], dt: float,
                 weights: dict | None, scales: dict | None, mode: str = "traces",
                 workers: int = 2) -> None:
        self.vehicle, self.targets, self.names, self.dt = vehicle, targets, names, dt
        self.mode, self.workers = mode, workers
        self.weights, self.scales = weights, scales
        self.n_sim = 0
        self.n_eval = 0
        # (objective, parameter vector); the vector is None until an objective is finite
        self.best: tuple[float, Any] = (math.inf, None)
        # the test's own mass and road load, applied once per target
        self.bases = [variant(vehicle, t.conditions.overrides) if t.conditions.overrides else vehicle
                      for t in targets]

    def per_test(self, x: np.ndarray) -> list[dict[str, float]] | None:
        ov = dict(zip(self.names, (float(v) for v in x)))
        out = []
        for base, tgt in zip(self.bases, self.targets):
            try:
                veh = variant(base, ov)
                sim = simulate(veh, tgt.conditions.cycle, dt=self.dt,
                               soc_initial=tgt.conditions.soc_initial)
            except ConfigError:
                return None
            self.n_sim += 1
            out.append(errors(tgt, sim.test))
        return out

    def __call__(self, x: np.ndarray) -> float:
        if self.mode == "batch":  # one objective per mode: score single points the same way
            return float(self.batch(np.asarray(x, dtype=float).reshape(-1, 1))[0])
        self.n_eval += 1
        errs = self.per_test(x)
        if errs is None:
            return PENALTY
        j = float(np.mean([objective(e, self.weights, self.scales) for e in errs]))
        if j < self.best[0]:
            self.best = (j, np.array(x, dtype=float))
        return j

    def batch(self, xs: np.ndarray) -> np.ndarray:
        """``xs`` of shape (n_params, n_candidates) as scipy's vectorized mode passes it."""
        if self.mode == "traces":
            return np.array([self(xs[:, k]) for k in range(xs.shape[1])])
        from vehval.sim.batch import simulate_batch

        n = xs.shape[1]
        rows = [dict(zip(self.names, (float(v) for v in xs[:, k]))) for k in range(n)]
        valid = []
        for k, r in enumerate(rows):
            try:
                variant(self.vehicle, r)
                valid.append(k)
            except ConfigError:
                pass
        js = np.full(n, PENALTY)
        per: dict[int, list[dict[str, float]]] = {k: [] for k in valid}
        if valid:
            for base, tgt in zip(self.bases, self.targets):
                res = simulate_batch(base, tgt.conditions.cycle, [rows[k] for k in valid], dt=self.dt,
                                     workers=self.workers, soc_initial=tgt.conditions.soc_initial)
                self.n_sim += len(valid)
                for k, summ in zip(valid, res):
                    per[k].append(errors_from_summary(tgt, summ))
        for k in valid:
            js[k] = float(np.mean([objective(e, self.weights, self.scales) for e in per[k]]))
            if js[k] < self.best[0]:
                self.best = (float(js[k]), xs[:, k].astype(float).copy())
        self.n_eval += n
        return js


def _start_and_bounds(veh0: Vehicle, names: list[str], start: Any,
                      bounds: dict[str, tuple[float, float]] | None,
                      rel_bounds: float) -> tuple[dict[str, float], dict[str, tuple[float, float]],
                                                  list[str]]:
    """Start value and bounds of each tuned parameter (SI), and the notes on both: the
    given start values used or ignored, and a start outside its bounds clipped."""
    given = start_values(start, names)
    check_start(veh0, given, names)
    x0 = {n: given.get(n, _value_of(veh0, n)) for n in names}
    notes = []
    if given:
        used = [n for n in names if n in given]
        notes.append("start values from the given start: " + (", ".join(
            f"{n} = {given[n]:.6g}" for n in used) or "none of the tuned parameters"))
        ignored = sorted(set(given) - set(names))
        if ignored:
            notes.append("given but not tuned (the vehicle's values are kept): " + ", ".join(ignored))
    bnds = {}
    for n in names:
        b = (bounds or {}).get(n) or (bounds or {}).get(n.split(".", 1)[1]) if bounds else None
        low, high = (float(b[0]), float(b[1])) if b else default_bounds(veh0, n, x0[n], rel_bounds)
        if not low < high:
            raise ConfigError(f"calibration bounds of '{n}': lower {low:g} must be below upper {high:g}")
        bnds[n] = (low, high)
        if not low <= x0[n] <= high:
            notes.append(f"start value of {n} ({x0[n]:.6g}) outside the bounds: clipped")
        x0[n] = min(max(x0[n], low), high)
    return x0, bnds, notes


def calibrate(tests: Sequence[Test], vehicle: Vehicle | str, parameters: Sequence[str], *,
              start: Any = None, bounds: dict[str, tuple[float, float]] | None = None,
              weights: dict[str, float] | None = None, scales: dict[str, float] | None = None,
              holdout_tests: Sequence[Test] = (), dt: float = 1.0, popsize: int = 8,
              maxiter: int = 40, polish: bool = True, seed: int = 0,
              signals: tuple[str, ...] = DEFAULT_SIGNALS, rel_bounds: float = 0.5,
              mode: str = "traces", workers: int = 2, smooth_hz: float | None = None,
              polish_evals: int | None = None,
              progress: Callable[[int, float], None] | None = None) -> CalibrationResult:
    """Tune ``parameters`` of ``vehicle`` to minimise the error over ``tests``.

    Parameters
    ----------
    tests : sequence of Test
        Tests to tune on (each simulated on its own speed trace, initial SOC, mass and road load).
    vehicle : Vehicle or name/path
        Model to calibrate.
    parameters : sequence of str
        Dotted names (``controller.engine_on_power_w``, ``body.aux_power_w``); a bare name
        means ``controller.<name>``.
    start : dict or analysis result, optional
        Start values (e.g. the control analysis' estimates); default the vehicle's values.
    bounds : dict, optional
        ``name -> (low, high)``; default ``start · (1 ± rel_bounds)`` clipped to the
        parameter's own constraints.
    weights, scales : dict, optional
        Objective weights and error scales (see :mod:`vehval.validate.objective`).
    holdout_tests : sequence of Test
        Tests not used for tuning; their error before and after is reported.
    dt : float
        Simulation step [s] during the search (1 s is about 10x faster than 0.1 s).
    popsize, maxiter : int
        Differential-evolution population multiplier and generations.
    polish : bool
        Run the Nelder-Mead polish after the evolution.
    polish_evals : int, optional
        Polish budget in evaluations per parameter (default 30).
    seed : int
        Seed of the search (the result is reproducible).
    signals : tuple of str
        Component signals whose NRMSE enters the objective.
    mode : {'traces', 'batch'}
        ``traces`` (default): every candidate is simulated with recording and scored on the
        full objective (step-wise engine state, component NRMSE). ``batch``: each
        generation goes through :func:`vehval.sim.batch.simulate_batch` (summaries only,
        parallel compiled loop); the objective then uses fuel, SOC, engine-on share and
        engine starts (:func:`vehval.validate.objective.errors_from_summary`), for the
        polish too. The before/after errors always use full simulations and comparisons.
    workers : int
        Threads of the batch simulation.
    smooth_hz : float, optional
        Zero-phase low-pass cut-off [Hz] of each test's measured speed given to the driver,
        in the search and in the before/after validations (default None: as measured).

    Returns
    -------
    CalibrationResult
    """
    t_start = time.perf_counter()
    if not tests:
        raise ConfigError("calibration needs at least one test")
    veh0 = load_vehicle(vehicle)
    names = [_full_name(p) for p in parameters]
    if not names:
        raise ConfigError("calibration needs at least one parameter (e.g. controller.engine_on_power_w)")
    if len(set(names)) != len(names):
        raise ConfigError(f"calibration parameters repeated: {', '.join(names)}")
    x0, bnds, notes = _start_and_bounds(veh0, names, start, bounds, rel_bounds)
    ids = [t.meta.test_id or f"test{i + 1}" for i, t in enumerate(tests)]
    hold_ids = [t.meta.test_id or f"holdout{i + 1}" for i, t in enumerate(holdout_tests)]
    targets = [make_target(t, veh0, dt, signals=signals, smooth_hz=smooth_hz) for t in tests]
    if mode not in MODES:
        raise ConfigError(f"calibration mode '{mode}': use one of {', '.join(MODES)}")
    prob = _Problem(veh0, targets, names, dt, weights, scales, mode, workers)
    xstart = np.array([x0[n] for n in names])
    j0 = prob(xstart)
    history = [j0]
    lo, hi = (np.array([bnds[n][k] for n in names]) for k in (0, 1))

    def cb() -> None:
        history.append(prob.best[0])
        if progress:
            progress(len(history) - 1, prob.best[0])

    method = de_polish(prob.batch, prob, lambda: prob.best, lo, hi, xstart, popsize=popsize,
                       maxiter=maxiter, seed=seed, polish=polish, polish_evals=polish_evals,
                       label=f"{mode} objective", callback=cb)
    if polish:
        history.append(prob.best[0])
    j_best, x_best = prob.best
    best = {n: float(v) for n, v in zip(names, x_best)}

    def evaluate(item: tuple[Test, str], values: dict[str, float]) -> dict[str, float]:
        return _errors(validate_test(item[0], veh0, dt=dt, overrides=dict(values),
                                     smooth_hz=smooth_hz))

    before, after = {}, {}
    roles = [("tuned", list(zip(tests, ids))), ("held out", list(zip(holdout_tests, hold_ids)))]
    for _role, (_t, tid), b, a in before_after(evaluate, roles, x0, best):
        before[tid], after[tid] = b, a
    prior = calibration_tests(veh0)
    notes += [f"held-out test {tid} is in-sample: the start vehicle was calibrated on it "
              f"({', '.join(params)})" for tid in hold_ids
              if (params := _prior_params(prior, tid)) is not None]
    rejected: dict[str, float] = {}
    worse = holdout_worse(before, after, hold_ids)
    if worse:
        # over-fitting guard: tuned values that fit the tuning tests but make the held-out
        # tests worse are not kept; the start values stay (with the tuned ones reported)
        rejected, best, j_best = best, dict(x0), j0
        after = {tid: dict(before[tid]) for tid in before}
        notes.append(f"over-fitting guard: the tuned values made the held-out tests worse "
                     f"({worse}): the start values are kept; tuned values in 'rejected'")
    return CalibrationResult(
        parameters=names, start=x0, bounds=bnds, best=best, objective_start=j0,
        objective_best=j_best, tests=ids, holdout=hold_ids, before=before, after=after,
        n_evaluations=prob.n_eval, n_simulations=prob.n_sim,
        elapsed_s=time.perf_counter() - t_start, method=method, dt=dt, vehicle=veh0,
        date=_dt.date.today().isoformat(), history=history, smooth_hz=smooth_hz, notes=notes,
        rejected=rejected, prior=prior)


def _prior_params(prior: dict[str, list[str]], tid: str) -> list[str] | None:
    """The parameters the start vehicle was calibrated on test ``tid`` with (None: not one
    of its calibration tests; matched by :func:`~vehval.calibration.provenance.same_test`)."""
    return next((p for name, p in prior.items() if same_test(tid, [name])), None)


def _errors(v) -> dict[str, float]:
    """The ladder's errors of one validation, the signed ones, and the normalised error of
    the fuel mass (``en``, ``u_meas_kg``, ``s_r``; U_model = 0: the tuned values carry no
    stated range)."""
    e = errors_of(v.comparison)
    entry = LadderEntry(v.comparison.test_id, v.comparison.cycle, "", dict(e), True)
    judge_fuel(entry, v.comparison, None, "hybrid")
    e["en"], e["u_meas_kg"], e["s_r"] = entry.en, entry.u_meas_kg, entry.s_r  # type: ignore[assignment]  # None: no fuel
    e["fuel_signed_pct"] = v.comparison.fuel_error * 100.0
    e["soc_final_signed_pct"] = v.comparison.soc_final_error * 100.0
    return e
