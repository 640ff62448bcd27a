"""Whole-test quantities (fuel, distance, SOC, engine on/off, energies) from a Test's signals.

The same function computes them from the measured signals (origin ``test``, falling back
to ``calc``) and from the simulated ones (origin ``simu``), on the same time grid, so the
test and the simulation are always reduced by identical formulas.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.equations.engine_state import ENGINE_OFF_RPM, ENGINE_ON_RPM, detect_engine_on
from vehval.fuels import economy
from vehval.integrals import battery_power
from vehval.test import Signal, Test
from vehval.validate.metrics import energies, integrate, on_off_events

#: Component powers [W] and the (torque, speed) pair that gives them when not recorded.
POWERS: dict[str, tuple[str, str] | None] = {
    "eng_pwr_out": ("eng_trq_out", "eng_spd_out"),
    "mot_pwr_out": ("mot_trq_out", "mot_spd_out"),
    "gen_pwr_out": ("gen_trq_out", "gen_spd_out"),
    "whl_pwr_out": ("whl_trq_out", "whl_spd"),
    "ess_pwr": ("ess_volt", "ess_curr"),
}


def pick_signal(test: Test, base: str, origin: str) -> Signal | None:
    """The signal of ``base`` to use for one side of a comparison.

    ``origin='simu'`` takes ``<base>_simu``; ``origin='test'`` the measured signal of the
    most trusted source, else the calculated ``<base>_calc`` (:meth:`vehval.test.Test.best`).
    None when the test has none of them.
    """
    return test.best(base, ("simu",) if origin == "simu" else ("test", "calc"))


def on_grid(test: Test, base: str, origin: str, grid: np.ndarray) -> np.ndarray | None:
    """Samples of ``base`` (see :func:`pick_signal`) on ``grid`` [s], or None if absent.

    Powers listed in :data:`POWERS` are computed from torque x speed (or volt x current)
    when the test has no power signal of their own.
    """
    sig = pick_signal(test, base, origin)
    if sig is not None:
        return _at(sig, grid)
    pair = POWERS.get(base)
    if pair:
        a, b = (pick_signal(test, n, origin) for n in pair)
        if a is not None and b is not None:
            if base == "ess_pwr":
                return battery_power(_at(a, grid), _at(b, grid))
            return _at(a, grid) * _at(b, grid)
    return None


def _at(sig: Signal, grid: np.ndarray) -> np.ndarray:
    """``sig.at(grid)``, short-cut when the signal is already sampled on ``grid``."""
    t = sig.time
    if t.size == grid.size and t.size and abs(t[0] - grid[0]) < 1e-9 and abs(t[-1] - grid[-1]) < 1e-9 \
            and float(np.max(np.abs(t - grid))) < 1e-9:
        return np.array(sig.values, dtype=float)
    return sig.at(grid)


def engine_on(test: Test, origin: str, grid: np.ndarray, method: str,
              on_speed_rpm: float = ENGINE_ON_RPM) -> np.ndarray | None:
    """Engine on flag (1/0, NaN where unknown) on ``grid`` [s].

    ``method='flag'`` uses ``eng_on``; ``'speed'`` and ``'fuel'`` read ``eng_spd_out`` or
    ``fuel_rate`` by the one rule of :mod:`vehval.equations.engine_state` (on above
    ``on_speed_rpm`` [rpm], off below the off threshold, with its debounce).
    """
    if method == "flag":
        v = on_grid(test, "eng_on", origin, grid)
        return None if v is None else np.where(np.isfinite(v), (v > 0.5).astype(float), np.nan)
    if method == "speed":
        v = on_grid(test, "eng_spd_out", origin, grid)
        if v is None:
            return None
        st = detect_engine_on(grid, v, on_rpm=on_speed_rpm,
                              off_rpm=min(ENGINE_OFF_RPM, on_speed_rpm))
        return np.where(np.isfinite(v), st.on.astype(float), np.nan)
    if method == "fuel":
        v = on_grid(test, "fuel_rate", origin, grid)
        if v is None:
            return None
        st = detect_engine_on(grid, np.full(grid.size, np.nan), fuel_rate=v)
        return np.where(np.isfinite(v), st.on.astype(float), np.nan)
    raise ValueError(f"unknown engine-on method '{method}' (flag, speed or fuel)")


def engine_on_method(test: Test, sim: Test | None = None) -> str | None:
    """The engine-on definition both sides support: flag, else speed, else fuel (None: none)."""
    for method, base in (("flag", "eng_on"), ("speed", "eng_spd_out"), ("fuel", "fuel_rate")):
        if pick_signal(test, base, "test") is not None and (
                sim is None or pick_signal(sim, base, "simu") is not None):
            return method
    return None


def _first_last(v: np.ndarray | None) -> tuple[float, float]:
    if v is None:
        return float("nan"), float("nan")
    ok = np.flatnonzero(np.isfinite(v))
    if not ok.size:
        return float("nan"), float("nan")
    return float(v[ok[0]]), float(v[ok[-1]])


def totals(test: Test, origin: str, grid: np.ndarray, *,
           fuel: Any = None, on_method: str | None = None,
           on_speed_rpm: float = ENGINE_ON_RPM) -> dict[str, Any]:
    """Whole-test quantities of one side (``origin`` test or simu) over ``grid`` [s].

    ``fuel`` (a resolved fuel, :func:`vehval.fuels.resolve_fuel`) gives the fuel energy,
    economy and consumption through :func:`vehval.fuels.economy`; without it they are NaN.

    Returns
    -------
    dict
        ``distance_m``, ``fuel_mass_kg``, ``fuel_energy_j``, ``fuel_economy_mpg``,
        ``fuel_consumption_l_per_100km``, ``soc_initial``, ``soc_final``, ``soc_delta``
        (final - initial), ``engine_on_share`` [-], ``engine_starts``, and for each power
        of :data:`POWERS` available ``<power>_pos_j`` and ``<power>_neg_j`` [J]. Missing
        inputs give NaN.
    """
    nan = float("nan")
    q: dict[str, Any] = {}
    spd = on_grid(test, "veh_spd", origin, grid)
    q["distance_m"] = integrate(grid, spd) if spd is not None else nan
    rate = on_grid(test, "fuel_rate", origin, grid)
    if rate is None:
        cum = on_grid(test, "fuel_mass", origin, grid)
        a, b = _first_last(cum)
        q["fuel_mass_kg"] = b - a
    else:
        q["fuel_mass_kg"] = integrate(grid, rate)
    fe = economy(q["fuel_mass_kg"], q["distance_m"], fuel)
    for key in ("fuel_energy_j", "fuel_economy_mpg", "fuel_consumption_l_per_100km"):
        q[key] = nan if fe[key] is None else fe[key]
    soc = on_grid(test, "ess_soc", origin, grid)
    q["soc_initial"], q["soc_final"] = _first_last(soc)
    q["soc_delta"] = q["soc_final"] - q["soc_initial"]
    on = engine_on(test, origin, grid, on_method, on_speed_rpm) if on_method else None
    if on is not None and np.any(np.isfinite(on)):
        q["engine_on_share"] = float(np.nanmean(on))
        q["engine_starts"] = int(on_off_events(grid, on)[0].size)
    else:
        q["engine_on_share"], q["engine_starts"] = nan, nan
    for pname in POWERS:
        p = on_grid(test, pname, origin, grid)
        if p is not None:
            q[f"{pname}_pos_j"], q[f"{pname}_neg_j"] = energies(grid, p)
    return q


def uniform_grid(t0: float, t1: float, dt: float) -> np.ndarray:
    """Uniform grid from ``t0`` to ``t1`` [s] with step ``dt`` [s] (end included if it falls on it)."""
    n = int(np.floor((t1 - t0) / dt + 1e-9)) + 1
    return t0 + dt * np.arange(max(n, 1))
