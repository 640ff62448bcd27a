"""The calibration objective: weighted, normalised errors of one simulation against one test.

A :class:`Target` holds what one test contributes, reduced once on the simulation grid
(measured speed trace, initial SOC, template constants, fuel, SOC, engine state and the
component signals). :func:`errors` reduces a simulation with the same formulas as
:func:`vehval.validate.compare.compare`, so the calibration minimises exactly the errors
the validation reports.

Objective of one test (dimensionless; the calibration averages it over the tests)::

    J = w_fuel · (e_fuel / s_fuel)^2 + w_soc · (e_soc / s_soc)^2
      + w_on · (e_on / s_on)^2 + w_signals · mean_b (NRMSE_b)^2

with ``e_fuel`` the relative fuel-mass error, ``e_soc`` the SOC error of the ladder
(|ΔSOC_sim − ΔSOC_test| / SOC_final,test), ``e_on`` the share of time steps with a
different engine state and ``NRMSE_b`` = RMSE / std(test) of each component signal ``b``.
The scales ``s`` (default 1 %, 1 %, 5 %) make one unit of J an error at the scale.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.equations.engine_state import ENGINE_ON_RPM
from vehval.sim.simulate import time_grid
from vehval.test import Test
from vehval.validate.conditions import Conditions, simulation_conditions
from vehval.validate.metrics import integrate, rmse
from vehval.validate.quantities import engine_on, engine_on_method, on_grid

DEFAULT_WEIGHTS = {"fuel": 1.0, "soc": 1.0, "engine_on": 0.5, "signals": 0.25, "starts": 0.25}
DEFAULT_SCALES = {"fuel": 0.01, "soc": 0.01, "engine_on": 0.05, "starts": 0.1}
DEFAULT_SIGNALS = ("eng_spd_out", "eng_trq_out", "ess_curr", "ess_soc")


@dataclass
class Target:
    """One test reduced for the calibration (SI on the simulation grid)."""

    test_id: str
    conditions: Conditions
    grid: np.ndarray
    fuel_kg: float
    soc_initial: float
    soc_final: float
    on: np.ndarray | None
    on_method: str | None
    signals: dict[str, np.ndarray] = field(default_factory=dict)
    signal_std: dict[str, float] = field(default_factory=dict)
    on_speed_rpm: float = ENGINE_ON_RPM


def _first_last(v: np.ndarray | None) -> tuple[float, float]:
    if v is None:
        return float("nan"), float("nan")
    ok = np.flatnonzero(np.isfinite(v))
    return (float(v[ok[0]]), float(v[ok[-1]])) if ok.size else (float("nan"), float("nan"))


def make_target(test: Test, vehicle: Any, dt: float, *, signals: tuple[str, ...] = DEFAULT_SIGNALS,
                use_constants: bool = True, on_speed_rpm: float = ENGINE_ON_RPM,
                smooth_hz: float | None = None) -> Target:
    """Reduce ``test`` once for the calibration (conditions, grid, measured quantities).

    ``smooth_hz`` low-passes the measured speed given to the driver (see
    :func:`vehval.validate.conditions.smooth_speed`).
    """
    cond = simulation_conditions(test, vehicle, use_constants=use_constants, smooth_hz=smooth_hz)
    grid, _ = time_grid(cond.cycle, dt)
    fuel = on_grid(test, "fuel_rate", "test", grid)
    soc = on_grid(test, "ess_soc", "test", grid)
    s0, s1 = _first_last(soc)
    # the engine state definition must be one the simulation also offers (flag/speed/fuel)
    method = engine_on_method(test)
    on = engine_on(test, "test", grid, method, on_speed_rpm) if method else None
    sig, sd = {}, {}
    for b in signals:
        v = on_grid(test, b, "test", grid)
        if v is not None and np.isfinite(v).sum() > 1 and np.nanstd(v) > 0:
            sig[b], sd[b] = v, float(np.nanstd(v))
    return Target(test_id=test.meta.test_id, conditions=cond, grid=grid,
                  fuel_kg=integrate(grid, fuel) if fuel is not None else float("nan"),
                  soc_initial=s0, soc_final=s1, on=on, on_method=method, signals=sig,
                  signal_std=sd, on_speed_rpm=on_speed_rpm)


def errors(target: Target, sim: Test) -> dict[str, float]:
    """Errors of one simulation (``<base>_simu`` on the target grid) against the target.

    Returns ``fuel`` (relative), ``soc`` (|ΔSOC_sim − ΔSOC_test| / SOC_final,test),
    ``engine_on`` (share of steps with a different state) and ``nrmse_<base>``.
    """
    g = target.grid
    out: dict[str, float] = {}
    fr = on_grid(sim, "fuel_rate", "simu", g)
    fuel = integrate(g, fr) if fr is not None else float("nan")
    out["fuel"] = (fuel - target.fuel_kg) / target.fuel_kg if target.fuel_kg > 0 else float("nan")
    s0, s1 = _first_last(on_grid(sim, "ess_soc", "simu", g))
    d_err = (s1 - s0) - (target.soc_final - target.soc_initial)
    out["soc"] = abs(d_err) / target.soc_final if target.soc_final > 0 else float("nan")
    if target.on is not None and target.on_method is not None:  # set together
        on_s = engine_on(sim, "simu", g, target.on_method, target.on_speed_rpm)
        ok = np.isfinite(target.on) & np.isfinite(on_s) if on_s is not None else None
        out["engine_on"] = (float(np.mean((target.on[ok] > 0.5) != (on_s[ok] > 0.5)))
                            if on_s is not None and ok is not None and ok.any()
                            else float("nan"))
    for b, v in target.signals.items():
        s = on_grid(sim, b, "simu", g)
        if s is not None:
            out[f"nrmse_{b}"] = rmse(v, s) / target.signal_std[b]
    return out


def errors_from_summary(target: Target, summary: dict[str, Any]) -> dict[str, float]:
    """Errors from a simulation summary only (batch mode of the calibration).

    ``fuel`` and ``soc`` as in :func:`errors` (from ``fuel_mass_kg``, ``soc_initial`` and
    ``soc_final``); ``engine_on`` becomes |on-time share_sim − share_test| (no time
    series: a lower bound of the step-wise disagreement) and ``starts`` the relative error
    of the number of engine starts. No component NRMSE.
    """
    out: dict[str, float] = {}
    fuel = float(summary.get("fuel_mass_kg", float("nan")))
    out["fuel"] = (fuel - target.fuel_kg) / target.fuel_kg if target.fuel_kg > 0 else float("nan")
    d_sim = float(summary.get("soc_final", float("nan"))) - float(summary.get("soc_initial", float("nan")))
    d_err = d_sim - (target.soc_final - target.soc_initial)
    out["soc"] = abs(d_err) / target.soc_final if target.soc_final > 0 else float("nan")
    if target.on is not None and np.isfinite(target.on).any():
        share_t = float(np.nanmean(target.on))
        share_s = float(summary.get("engine_on_fraction", float("nan")))
        out["engine_on"] = abs(share_s - share_t)
        from vehval.validate.metrics import on_off_events
        n_t = on_off_events(target.grid, target.on)[0].size
        n_s = float(summary.get("engine_starts", float("nan")))
        out["starts"] = (n_s - n_t) / max(n_t, 1)
    return out


def objective(err: dict[str, float], weights: dict[str, float] | None = None,
              scales: dict[str, float] | None = None) -> float:
    """Weighted sum of squared normalised errors of one test (see the module docstring).

    A term that cannot be computed (NaN) is skipped, so tests without a signal still count.
    """
    w = {**DEFAULT_WEIGHTS, **(weights or {})}
    s = {**DEFAULT_SCALES, **(scales or {})}
    j = 0.0
    for key in ("fuel", "soc", "engine_on", "starts"):
        e = err.get(key, float("nan"))
        if w.get(key, 0.0) and np.isfinite(e):
            j += w[key] * (e / s[key]) ** 2
    nr = [v for k, v in err.items() if k.startswith("nrmse_") and np.isfinite(v)]
    if nr and w.get("signals", 0.0):
        j += w["signals"] * float(np.mean(np.square(nr)))
    return float(j)


__all__ = ["Target", "make_target", "errors", "errors_from_summary", "objective", "DEFAULT_WEIGHTS", "DEFAULT_SCALES",
           "DEFAULT_SIGNALS", "RPM"]
