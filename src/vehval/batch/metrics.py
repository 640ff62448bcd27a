"""Key metrics of one test, computed from its measured signals (SI in, SI out).

The same function serves the batch runner and a direct single-test run, so the catalog
can be checked against either. Integrals use the trapezoidal rule on each signal's own
time base over its finite samples.
"""

from __future__ import annotations

import math
from typing import Any, Collection, Mapping

import numpy as np

from vehval.fuels import economy, resolve_fuel
from vehval.integrals import battery_power, integral
from vehval.test import Signal, Test


def _kept(selected: Mapping[str, str] | Collection[str] | None) -> list[str] | None:
    """Full names of the measured signals QA kept (None: QA did not run)."""
    if selected is None:
        return None
    return list(selected.values() if isinstance(selected, Mapping) else selected)


def _finite(sig: Signal) -> tuple[np.ndarray, np.ndarray]:
    ok = np.isfinite(sig.time) & np.isfinite(sig.values)
    return sig.time[ok], sig.values[ok]


def _integral(t: np.ndarray, v: np.ndarray) -> float | None:
    """:func:`vehval.integrals.integral`, None (not NaN) when it cannot be formed."""
    x = integral(t, v)
    return x if math.isfinite(x) else None


def _product(a: Signal, b: Signal) -> tuple[np.ndarray, np.ndarray]:
    """Effort x flow on ``a``'s time base (voltage x current by :func:`battery_power`)."""
    t, va = _finite(a)
    vb = b.at(t)
    ok = np.isfinite(vb)
    if a.name.startswith("ess_volt"):
        return t[ok], battery_power(va[ok], vb[ok])
    return t[ok], va[ok] * vb[ok]


def _power(test: Test, pwr: str, effort: str, flow: str,
           kept: list[str] | None) -> tuple[np.ndarray, np.ndarray] | None:
    s = test.best(pwr, ("test",), kept=kept)
    if s is not None:
        return _finite(s)
    e, f = test.best(effort, ("test",), kept=kept), test.best(flow, ("test",), kept=kept)
    if e is not None and f is not None:
        return _product(e, f)
    return None


#: Whole-test figures taken from the results stage when it ran.
RESULTS_KEYS = ("distance_m", "fuel_mass_kg", "fuel_economy_mpg", "fuel_consumption_l_per_100km",
                "fuel_energy_j")


def test_metrics(test: Test, selected: Mapping[str, str] | Collection[str] | None = None,
                 fuel: Any = None, results: Any = None) -> dict[str, Any]:
    """Key metrics of a test.

    Parameters
    ----------
    test : Test
        An imported test (measured signals ``*_test`` in SI).
    selected : dict or collection of str, optional
        The measured signals QA's selection kept: their full names, or base name -> full
        name. When given (QA ran), only those signals are used; a quantity QA kept in no
        source gives None. Each signal is chosen by :meth:`vehval.test.Test.best`, the
        rule every stage follows.
    fuel : Fuel or ResolvedFuel, optional
        The test fuel (the results stage's); else the one :func:`vehval.fuels.resolve_fuel`
        finds for the test (template ``fuel:`` kept at import, else the constants
        ``fuel_density_kg_per_m3`` / ``fuel_lhv_j_per_kg``). Without one, fuel economy and
        energy are None: there is no default fuel.
    results : vehval.results.TestResults, optional
        The results stage of the test: its whole-test distance, fuel mass, fuel economy,
        consumption and energy are the ones stated (one owner of each figure); the
        integrals below serve tests without results.

    Returns
    -------
    dict
        ``duration_s`` [s], ``distance_m`` [m], ``fuel_mass_kg`` [kg], ``fuel_economy_mpg``
        [mile/US gal], ``fuel_consumption_l_per_100km`` [L/100 km], ``soc_initial``,
        ``soc_final``, ``soc_change`` [-], ``fuel_energy_j``, ``ess_energy_j`` (net,
        positive discharged), ``eng_energy_j`` (positive brake energy),
        ``tractive_energy_j`` (positive) [J]; None where the signals are missing.
    """
    if fuel is None:
        fuel = resolve_fuel(test=test)
    out: dict[str, Any] = {k: None for k in (
        "duration_s", "distance_m", "fuel_mass_kg", "fuel_economy_mpg",
        "fuel_consumption_l_per_100km", "soc_initial", "soc_final", "soc_change",
        "fuel_energy_j", "ess_energy_j", "eng_energy_j", "tractive_energy_j")}
    if len(test):
        t0, t1 = test.span()
        out["duration_s"] = float(t1 - t0)
    kept = _kept(selected)
    spd = test.best("veh_spd", ("test",), kept=kept)
    if spd is not None:
        out["distance_m"] = _integral(*_finite(spd))
    rate = test.best("fuel_rate", ("test",), kept=kept)
    if rate is not None:
        out["fuel_mass_kg"] = _integral(*_finite(rate))
    fm, dist = out["fuel_mass_kg"], out["distance_m"]
    if fm is not None:
        fe = economy(fm, dist if dist is not None else math.nan, fuel)
        out["fuel_energy_j"] = fe["fuel_energy_j"]
        if fe["fuel_volume_m3"] is not None and dist is not None and fm > 0 and dist > 0:
            out["fuel_economy_mpg"] = fe["fuel_economy_mpg"]
            out["fuel_consumption_l_per_100km"] = fe["fuel_consumption_l_per_100km"]
    if results is not None:
        for key in RESULTS_KEYS:
            out[key] = results.value("test", key)
    soc = test.best("ess_soc", ("test",), kept=kept)
    if soc is not None:
        _, v = _finite(soc)
        if v.size:
            out["soc_initial"], out["soc_final"] = float(v[0]), float(v[-1])
            out["soc_change"] = float(v[-1] - v[0])
    ess = _power(test, "ess_pwr", "ess_volt", "ess_curr", kept)
    if ess is not None:
        out["ess_energy_j"] = _integral(*ess)
    eng = _power(test, "eng_pwr_out", "eng_trq_out", "eng_spd_out", kept)
    if eng is not None:
        t, p = eng
        out["eng_energy_j"] = _integral(t, np.maximum(p, 0.0))
    trac = _power(test, "whl_pwr_out", "veh_frc_in", "veh_spd", kept)
    if trac is not None:
        t, p = trac
        out["tractive_energy_j"] = _integral(t, np.maximum(p, 0.0))
    return {k: (v if v is None or math.isfinite(v) else None) for k, v in out.items()}
