"""Calibration of a conventional vehicle model on measured fuel, checked on held-out tests.

The tuning tests are driven with their own speed traces (:func:`predict_trace`); the
objective is the sum of squared relative fuel errors. Bounded Powell search over the named
parameters (dotted paths); bounds: efficiencies (0.5, 1], accessory power [0, 5000] W,
any other parameter within ±50 % of its start. Held-out tests are predicted before and
after. The search, the hold-out evaluation and the provenance of the tuned values in the
vehicle file are the calibration engine's (:mod:`vehval.calibration`).
"""

from __future__ import annotations

import datetime as _dt
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vehval.calibration import (
    Provenance,
    before_after,
    powell,
    vehicle_with_values,
    write_vehicle_yaml,
)
from vehval.calibration.provenance import bounds_text
from vehval.errors import ConfigError
from vehval.identify.predict import predict_trace
from vehval.identify.traces import Trace

if TYPE_CHECKING:
    from vehval.vehicle import ConventionalVehicle

DEFAULT_PARAMS = ("engine_control.accessory_power_w", "gearbox.efficiency")


def _bounds(name: str, x0: float) -> tuple[float, float]:
    if name.endswith("efficiency"):
        return 0.5, 1.0
    if name.endswith("accessory_power_w"):
        return 0.0, 5000.0
    lo, hi = sorted((0.5 * x0, 1.5 * x0))
    return (lo, hi) if hi > lo else (-1.0, 1.0)


@dataclass
class ConventionalCalibration:
    """Start and best values, per-test fuel errors before/after, search statistics."""

    parameters: list[str]
    start: dict[str, float]
    best: dict[str, float]
    tests: list[dict]
    objective_start: float
    objective_best: float
    n_simulations: int
    elapsed_s: float
    vehicle: ConventionalVehicle | None = None
    notes: list[str] = field(default_factory=list)
    date: str = field(default_factory=lambda: _dt.date.today().isoformat())

    def write_vehicle(self, path: str | Path) -> Path:
        """Write the calibrated vehicle YAML atomically; it loads with ``load_vehicle``."""
        return write_vehicle_yaml(self.vehicle, path, "vehval calibrate")

    def to_dict(self) -> dict:
        return {"architecture": "conventional", "parameters": self.parameters,
                "start": self.start, "best": self.best, "tests": self.tests,
                "objective_start": self.objective_start, "objective_best": self.objective_best,
                "n_simulations": self.n_simulations, "elapsed_s": self.elapsed_s,
                "notes": self.notes}


def _fuel_errors(veh, traces: list[Trace]) -> list[dict]:
    return [{k: v for k, v in predict_trace(veh, t).items() if k not in ("sim", "trace")}
            for t in traces]


def calibrate_conventional(vehicle, tuning: list[Trace], names: list[str],
                           holdout: Sequence[Trace] = (), maxiter: int = 60
                           ) -> ConventionalCalibration:
    """Tune ``names`` of ``vehicle`` on the fuel of ``tuning`` traces (see module doc)."""
    params = vehicle.parameters()
    unknown = [n for n in names if n not in params]
    if unknown:
        raise ConfigError(f"--params: {', '.join(unknown)} is not a scalar parameter of "
                          f"{vehicle.name} (e.g. {', '.join(DEFAULT_PARAMS)})")
    if not tuning:
        raise ConfigError("no tuning test given")
    x0 = np.array([float(params[n]) for n in names])
    bounds = [_bounds(n, v) for n, v in zip(names, x0)]
    meas = np.array([t.fuel[t.t >= 0].sum() * t.dt for t in tuning])
    t0 = time.perf_counter()

    def objective(x):
        veh = vehicle.with_overrides(dict(zip(names, map(float, x))))
        errs = []
        for tr, m in zip(tuning, meas):
            p = predict_trace(veh, tr)
            errs.append(p["fuel_predicted_g"] / (m * 1e3) - 1.0)
        return float(np.sum(np.square(errs)))

    found = powell(objective, x0, bounds, maxiter)
    start = dict(zip(names, map(float, x0)))
    best = dict(zip(names, map(float, found.x)))
    prov = Provenance(
        by="vehval calibrate", tests=[t.test_id for t in tuning],
        objective="sum of squared relative fuel errors", start_value=found.start_value,
        best_value=found.value, method=found.method, start=start,
        ranges={n: bounds_text(*b) for n, b in zip(names, bounds)},
        dt=float(tuning[0].dt), holdout=[t.test_id for t in holdout])
    tuned = vehicle_with_values(vehicle, best, prov.text)
    rows = []
    for role, _tr, b, a in before_after(
            lambda tr, values: _fuel_errors(vehicle.with_overrides(values), [tr])[0],
            [("tune", tuning), ("holdout", list(holdout))], start, best):
        # a held-out test the start vehicle was identified on is a fit too (predict's rule)
        rows.append({"test": b["test"], "role": role, "cycle": b["cycle"],
                     "in_sample": role == "tune" or bool(b.get("in_sample")),
                     "fuel_measured_g": b["fuel_measured_g"],
                     "error_rel_before": b["error_rel"], "error_rel_after": a["error_rel"],
                     "phases_after": a["phases"]})
    return ConventionalCalibration(
        parameters=list(names), start=start, best=best, tests=rows,
        objective_start=found.start_value, objective_best=found.value,
        n_simulations=found.n_evaluations, elapsed_s=time.perf_counter() - t0, vehicle=tuned,
        date=prov.date)
