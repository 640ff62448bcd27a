"""Calibrate unpublished vehicle parameters on EPA certification tests.

A manufacturer publishes ratings, not its control strategy. :func:`calibrate_on_tests`
chooses the values of a few parameters (typically controller thresholds and gains) that
make the model reproduce one set of EPA tests, so that another set (other originator, other
road loads) can judge the model honestly. The search is a full grid over the given values,
then coordinate refinement (midpoints towards each neighbour, halving each round;
:func:`vehval.calibration.grid_refine`): the fuel economy of a hybrid is a stepwise
function of its thresholds, so a gradient method would stall on its plateaus. The
provenance written into the vehicle file is the calibration engine's
(:class:`vehval.calibration.Provenance`).

Bounds: a grid of at most :data:`MAX_GRID_POINTS` settings; before the grid runs, the time
it takes is estimated from the measured time of the start values' simulation (settings x
that time / workers) and stated, and a run estimated over :data:`LONG_RUN_S` is refused
unless asked for (``max_seconds=None``).

Objective: the root-mean-square relative error of the judged figures of the calibration
tests, exactly those :func:`vehval.epa.validation.validate_tests` judges; the cold-start
figures are included at every grid point when a cold-start parameter is calibrated (or the
vehicle already models the cold start), so every setting is scored on the same figures.
"""

from __future__ import annotations

import datetime as _dt
import difflib
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vehval.calibration import Provenance, grid_refine, vehicle_with_values, write_vehicle_yaml
from vehval.calibration.provenance import grid_text
from vehval.calibration.search import grid_method
from vehval.epa.reader import EpaTest
from vehval.epa.validation import (
    COLD_START_PARAMS,
    EpaValidation,
    has_cold_start_model,
    validate_tests,
)
from vehval.errors import ConfigError
from vehval.vehicle import Vehicle, load_vehicle

#: Most settings of one grid (the product of the numbers of values): at about 1 s per
#: setting and test, 1,000 settings of 6 tests are 1-2 hours on one core; --refine then
#: refines between the values, so a finer grid is rarely needed.
MAX_GRID_POINTS = 1000
#: Estimated run time [s] above which a calibration runs only when asked for (`--long-run`).
LONG_RUN_S = 900.0
#: Estimated run time [s] from which the estimate is stated before the grid runs.
STATE_ESTIMATE_S = 10.0


def full_name(name: str) -> str:
    """The dotted parameter name (a bare name is ``controller.NAME``)."""
    return name if "." in name else f"controller.{name}"


def grid_from_pairs(pairs: list[tuple[str, list[float]]]) -> dict[str, list[float]]:
    """``{name: values}`` of ``(name, values)`` pairs; two grids of one parameter (also
    ``soc_gain_w`` and ``controller.soc_gain_w``) are refused, naming it."""
    grid: dict[str, list[float]] = {}
    given: dict[str, str] = {}
    for name, values in pairs:
        full = full_name(name)
        if full in given:
            raise ConfigError(f"parameter '{full}' is given two grids ('{given[full]}' and "
                              f"'{name}'): give all its values in one NAME=v1,v2,...")
        given[full] = name
        grid[name] = list(values)
    return grid


def _duration(seconds: float) -> str:
    """``45 s``, ``12 min``, ``3 h 20 min``."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60):02d} min"


def judged_errors(val: EpaValidation, with_cold: bool = False) -> np.ndarray:
    """Relative errors [-] of the judged figures of a validation (``with_cold``: and of the
    cold-start figures whether or not the vehicle models the cold start)."""
    return np.array([c.error for c in val.comparisons
                     if c.judged or (with_cold and c.cold_start and not c.list_doubtful
                                     and not c.analytically_derived)])


def _score(val: EpaValidation, with_cold: bool = False) -> tuple[float, float]:
    err = judged_errors(val, with_cold)
    if err.size == 0 or not np.all(np.isfinite(err)):
        return math.inf, math.inf
    return float(np.sqrt(np.mean(err ** 2))), float(np.max(np.abs(err)))


@dataclass
class EpaCalibration:
    """Result of :func:`calibrate_on_tests` (errors relative, [-])."""

    vehicle: Vehicle
    grid: dict[str, list[float]]
    tests: list[str]
    best: dict[str, float]
    start_rms: float
    best_rms: float
    best_max: float
    evaluations: list[dict[str, Any]] = field(default_factory=list)
    dt: float = 0.2
    date: str = field(default_factory=lambda: _dt.date.today().isoformat())

    refine_rounds: int = 2

    def provenance(self, name: str) -> str:
        """Source text recorded for a calibrated parameter in the vehicle file
        (:class:`vehval.calibration.Provenance`)."""
        start = self.vehicle.parameters()
        return Provenance(
            by="vehval epa calibrate", tests=self.tests,
            objective="RMS error of the judged figures", start_value=self.start_rms,
            best_value=self.best_rms, percent=True,
            method=grid_method(self.refine_rounds),
            start={n: float(start[n]) for n in self.grid},
            ranges={n: grid_text(v) for n, v in self.grid.items()}, dt=self.dt,
            details=["tests of the EPA Test Car Lists"], date=self.date).text(name)

    def calibrated_vehicle(self) -> Vehicle:
        """The validated vehicle with the calibrated values and their provenance."""
        return vehicle_with_values(self.vehicle, self.best, self.provenance)

    def write_vehicle(self, path: str | Path) -> Path:
        """Write the calibrated vehicle YAML atomically; it loads with ``load_vehicle``."""
        return write_vehicle_yaml(self.calibrated_vehicle(), path, "vehval epa calibrate")

    def to_dict(self) -> dict[str, Any]:
        return {"vehicle": self.vehicle.name, "tests": self.tests, "dt_s": self.dt,
                "grid": self.grid, "best": self.best,
                "start": {k: self.vehicle.parameters()[k] for k in self.grid},
                "start_rms_error": self.start_rms, "best_rms_error": self.best_rms,
                "best_max_abs_error": self.best_max, "n_evaluations": len(self.evaluations),
                "evaluations": self.evaluations}


def _unknown_text(veh: Vehicle, name: str, full: str, params: list[str]) -> str:
    """Message for a parameter the vehicle does not have: the closest names, those of the
    same last part in any block (``accessory_power_w`` -> ``engine_control.``), else the
    vehicle's blocks (a conventional car has no ``controller``)."""
    last = full.rpartition(".")[2]
    close = [p for p in params if p.rpartition(".")[2] == last]
    close += [p for p in difflib.get_close_matches(full, params, n=3, cutoff=0.75)
              if p not in close]
    text = f"unknown parameter '{name}' of vehicle {veh.name}"
    if "." not in name:
        text += f" (a bare name is {full})"
    if close:
        return text + f"; did you mean {', '.join(close[:4])}?"
    blocks = sorted({p.partition(".")[0] for p in params})
    return text + (f"; its parameters are in the blocks {', '.join(blocks)} (write "
                   f"BLOCK.NAME, e.g. {sorted(params)[0]})")


def _check_grid(veh: Vehicle, grid: dict[str, list[float]]) -> dict[str, list[float]]:
    params = veh.parameters()
    if not grid:
        raise ConfigError("give at least one parameter to calibrate (NAME=v1,v2,...)")
    grid_from_pairs(list(grid.items()))  # one grid per parameter, whatever its spelling
    sizes = [len({float(v) for v in values}) for values in grid.values()]
    if math.prod(sizes) > MAX_GRID_POINTS:
        raise ConfigError(f"the grid has {math.prod(sizes):,} settings "
                          f"({' x '.join(map(str, sizes))} values), more than the "
                          f"{MAX_GRID_POINTS:,} of one calibration: give fewer values "
                          "(--refine refines between them)")
    out = {}
    for name, values in grid.items():
        full = full_name(name)
        if full not in params:
            raise ConfigError(_unknown_text(veh, name, full, list(params)))
        vals = sorted({float(v) for v in values})
        if not vals or not all(math.isfinite(v) for v in vals):
            raise ConfigError(f"parameter '{name}': give finite values")
        for v in vals:  # each value within the parameter's own constraints
            try:
                veh.with_overrides({full: v})
            except ConfigError as exc:
                raise ConfigError(f"parameter '{name}' = {v:g} is not a valid value: "
                                  f"{str(exc).rpartition(': ')[2]}") from None
        out[full] = vals
    return out


def _evaluate(args) -> tuple[float, float]:
    """Score of one setting (module level so worker processes can run it)."""
    base, names, values, tests, dt, with_cold = args
    try:
        veh = base.with_overrides(dict(zip(names, values)))
    except ConfigError:  # value outside the parameter's own constraints
        return math.inf, math.inf
    return _score(validate_tests(veh, tests, dt=dt), with_cold)


def _estimate(base: Vehicle, tests: list[EpaTest], dt: float, n_settings: int, workers: int,
              measured_s: float, max_seconds: float | None,
              notify: Callable[[str], None] | None) -> None:
    """State the estimated run time of ``n_settings`` settings (``measured_s``: one
    setting's time, measured on the start values); refuse it over ``max_seconds``."""
    parallel = max(1, min(workers, n_settings))
    est = n_settings * measured_s / parallel
    if est >= STATE_ESTIMATE_S:     # measure again warm (the first run may compile kernels)
        t0 = time.perf_counter()
        validate_tests(base, tests, dt=dt)
        measured_s = min(measured_s, time.perf_counter() - t0)
        est = n_settings * measured_s / parallel
    text = (f"at most {n_settings:,} settings x {len(tests)} tests, {measured_s:.2g} s per "
            f"setting measured on the start values, {parallel} worker(s): about "
            f"{_duration(est)}")
    if max_seconds is not None and est > max_seconds:
        raise ConfigError(f"the calibration would take about {_duration(est)} ({text}), more "
                          f"than the {_duration(max_seconds)} run without asking: give fewer "
                          "values or tests, more --workers, or --long-run to run it")
    if notify is not None and est >= STATE_ESTIMATE_S:
        notify(f"epa calibrate: {text}")


def calibrate_on_tests(vehicle: Vehicle | str | Path, tests: list[EpaTest],
                       grid: dict[str, list[float]], dt: float = 0.2,
                       refine_rounds: int = 2, workers: int = 1,
                       max_seconds: float | None = None,
                       notify: Callable[[str], None] | None = None) -> EpaCalibration:
    """Grid search, then coordinate refinement, of ``grid``'s parameters on ``tests``.

    Parameters
    ----------
    vehicle : Vehicle, name or path
        Starting vehicle; its other parameters are kept.
    tests : list of EpaTest
        Calibration tests (those the simulator cannot run are skipped, as in validation).
    grid : dict
        Dotted parameter name (a bare name means ``controller.<name>``) -> candidate values.
    dt : float
        Simulation step [s].
    refine_rounds : int
        Rounds of coordinate refinement after the grid (0: grid only).
    workers : int
        Processes evaluating settings in parallel (1: in this process; 0: one per CPU, at
        most 8). The result does not depend on it. Workers are spawned: a script calling this with ``workers > 1`` needs
        the ``if __name__ == "__main__":`` guard.
    max_seconds : float, optional
        Refuse (ConfigError) a calibration estimated to take longer [s] (None: no limit).
    notify : callable, optional
        Receives the estimated run time before the grid runs (when it is 10 s or more).
    """
    base = load_vehicle(vehicle)
    grid = _check_grid(base, grid)
    names = list(grid)
    # calibrating a cold-start parameter scores the cold-start figures at every setting
    with_cold = has_cold_start_model(base) or any(n in COLD_START_PARAMS for n in names)
    t0 = time.perf_counter()
    start_val = validate_tests(base, tests, dt=dt)
    measured = time.perf_counter() - t0
    if judged_errors(start_val, with_cold).size == 0:
        raise ConfigError("the calibration tests have no judged figure: select FTP-75, "
                          "HWFET or US06 tests")
    start_rms = _score(start_val, with_cold)[0]
    if workers <= 0:
        workers = min(os.cpu_count() or 1, 8)
    n_settings = math.prod(len(v) for v in grid.values()) + 2 * len(grid) * refine_rounds
    _estimate(base, tests, dt, n_settings, workers, measured, max_seconds, notify)
    pool = None
    if workers > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        pool = ProcessPoolExecutor(max_workers=workers,
                                   mp_context=multiprocessing.get_context("spawn"))

    def evaluate(settings: list[tuple[float, ...]]) -> list[tuple[float, float]]:
        jobs = [(base, names, v, tests, dt, with_cold) for v in settings]
        return list(pool.map(_evaluate, jobs) if pool is not None else map(_evaluate, jobs))

    try:
        found = grid_refine(grid, evaluate, refine_rounds)
    finally:
        if pool is not None:
            pool.shutdown()
    evals = [{"values": dict(zip(names, v)), "rms_error": sc[0], "max_abs_error": sc[1]}
             for v, sc in found.evaluations]
    best = found.best
    rms, mx = found.score
    if not math.isfinite(rms):
        raise ConfigError("no setting of the grid gives finite figures on these tests (a run "
                          "failed or a parameter combination is invalid); widen or move the "
                          "grid")
    return EpaCalibration(vehicle=base, grid=grid,
                          tests=[p.test.label for p in start_val.predictions],
                          best={n: float(v) for n, v in zip(names, best)},
                          start_rms=start_rms, best_rms=rms, best_max=mx, evaluations=evals,
                          dt=dt, refine_rounds=refine_rounds)
