"""Measured traces of a conventional-car test on one uniform grid, checked for identification.

A :class:`Trace` holds what identification needs from one imported test: vehicle speed and
acceleration, tractive force, engine speed and fuel rate (SI, 10 Hz by default), the phase
number and the template constants. :func:`trace_from_test` refuses, in one line, tests
that cannot identify a conventional car (a hybrid, no engine speed, no fuel rate).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from vehval.errors import SignalError
from vehval.fuels import resolve_fuel
from vehval.test import Test, hybrid_signals, is_hybrid
from vehval.vehicle.definition import absent_categories

if TYPE_CHECKING:
    from vehval.fuels import ResolvedFuel
    from vehval.results import TestResults

REQUIRED = {
    "veh_spd": "vehicle speed",
    "veh_frc_in": "tractive force at the wheels (dyno force)",
    "eng_spd_out": "engine speed",
    "fuel_rate": "fuel mass rate",
}


class IdentificationError(SignalError):
    """The tests given cannot identify the requested model (the message says what is missing)."""


@dataclass
class Trace:
    """One test on a uniform grid (SI): time [s], speed [m/s], acceleration [m/s^2],
    tractive force [N], engine speed [rad/s], fuel rate [kg/s], phase number."""

    test_id: str
    cycle: str
    t: np.ndarray
    v: np.ndarray
    a: np.ndarray
    force: np.ndarray
    w_eng: np.ndarray
    fuel: np.ndarray
    phase: np.ndarray
    constants: dict = field(default_factory=dict)
    amb_temp_c: float = float("nan")
    coolant_start_c: float = float("nan")  # engine coolant over the first 5 s [°C]
    file: str = ""
    results: TestResults | None = None  # the results stage of the test, when computed
    test_fuel: ResolvedFuel | None = None  # vehval.fuels.ResolvedFuel of the test (template fuel:/constants)

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0])


def smooth(x: np.ndarray, n: int) -> np.ndarray:
    """Centred moving average over ``n`` samples (edges use the available samples)."""
    if n <= 1:
        return np.asarray(x, float)
    k = np.ones(n)
    num = np.convolve(x, k, mode="same")
    den = np.convolve(np.ones_like(x), k, mode="same")
    return num / den


def acceleration(v: np.ndarray, dt: float, window_s: float = 0.5) -> np.ndarray:
    """Acceleration [m/s^2]: centred average over ``window_s``, then central difference."""
    return np.gradient(smooth(v, max(round(window_s / dt), 1)), dt)


def hybrid_refusal(test: Test, vehicle: object = None) -> str | None:
    """The one line refusing to identify a hybrid test, None for a conventional one.

    The decision is :func:`vehval.test.is_hybrid`'s: the vehicle file's architecture when
    one is given (the template's ``vehicle:``), else a hybrid-component signal in the test.
    """
    arch, name = getattr(vehicle, "architecture", None), getattr(vehicle, "name", None)
    where = ", ".join(test.meta.files) or test.meta.test_id or "the test"
    if arch is not None and "engine" in absent_categories(str(arch)):
        return (f"{where}: its vehicle {name or ''} is {arch}, a car without an engine: "
                "identify and the conventional model take conventional cars only; use "
                "`vehval results` for its energy figures")
    if not is_hybrid(test, vehicle, measured_only=False):
        return None
    why = (f"it has {', '.join(hybrid_signals(test, measured_only=False)[:3])}" if arch is None
           else f"its vehicle {name} is {arch}" if name else f"its vehicle file says {arch}")
    return (f"{where}: this is a hybrid ({why}): identify and the conventional model take "
            "conventional cars only; use `vehval validate` or `vehval calibrate` with a "
            "power-split vehicle file (--vehicle)")


#: engine speed above which the engine counts as turning [rad/s] (about 300 rpm)
TURNING_RAD_S = 30.0
#: fuel rate under which a sample reads no fuel [kg/s] (1 mg/s)
NO_FUEL_KG_S = 1e-6
#: engine running this long with no fuel anywhere: a dead fuel channel [s]
DEAD_FUEL_S = 10.0


def dead_fuel_channel(tr: Trace) -> str | None:
    """Why the fuel channel of ``tr`` cannot be fitted (None: it can): it reads no fuel in
    any sample (0 or missing throughout) while the engine turns for :data:`DEAD_FUEL_S` or
    more. A channel not recorded in that test, or a meter not connected: fitted, its zeros
    would pull the fuel map toward no fuel at power."""
    turning = float(np.count_nonzero(tr.w_eng > TURNING_RAD_S)) * tr.dt
    fuel = np.nan_to_num(tr.fuel, nan=0.0)
    if turning >= DEAD_FUEL_S and not np.any(fuel > NO_FUEL_KG_S):
        what = "has no value" if not np.isfinite(tr.fuel).any() else "reads 0"
        return (f"{tr.test_id}: its fuel rate {what} throughout while the engine "
                f"turns for {turning:.0f} s (a channel not recorded or a meter not connected)")
    return None


def negative_fuel_channel(tr: Trace) -> str | None:
    """Why the fuel channel of ``tr`` is not a fuel flow (None: it may be): while the engine
    turns it reads negative more often than positive and sums below zero (a sign slip of the
    channel or its template ``scale``; a few negative samples of meter noise pass)."""
    fuel = tr.fuel[(tr.w_eng > TURNING_RAD_S) & np.isfinite(tr.fuel)]
    neg, pos = np.count_nonzero(fuel < -NO_FUEL_KG_S), np.count_nonzero(fuel > NO_FUEL_KG_S)
    if neg <= pos or float(np.sum(fuel)) >= 0.0:
        return None
    return (f"{tr.file or tr.test_id}: its fuel rate is negative in {neg} of the "
            f"{fuel.size} samples with the engine turning (down to {fuel.min() * 1e3:.3g} g/s): "
            "no fuel flow is; check the channel's sign (its unit or scale in the template)")


def trace_from_test(test: Test, dt: float = 0.1, vehicle: object = None) -> Trace:
    """Trace of ``test`` on a ``dt`` grid from time 0 (the start of the drive) to its end.

    Parameters
    ----------
    vehicle : Vehicle, optional
        The test's vehicle file (the template's ``vehicle:``): its architecture decides
        whether the test is a hybrid (:func:`hybrid_refusal`).

    Raises
    ------
    IdentificationError
        The test is a hybrid, or lacks one of the signals in :data:`REQUIRED`.
    """
    where = test.meta.files[0] if test.meta.files else test.meta.test_id
    refusal = hybrid_refusal(test, vehicle)
    if refusal:
        raise IdentificationError(refusal)
    sig = {}
    for base, what in REQUIRED.items():
        s = test.best(base, ("test",))  # the one selection rule
        if s is None:
            only = ("; a test with only speed and fuel calibrates a car built from its public "
                    "specifications instead (vehval epa vehicle ... --calibrate FILE, "
                    "docs/validation.md)"
                    if all(test.best(b, ("test",)) is None for b in REQUIRED
                           if b not in ("veh_spd", "fuel_rate")) else "")
            raise IdentificationError(
                f"{where}: no {what} signal ({base}_test): identification of a conventional "
                f"car needs it; map the channel to {base}_test in the template{only}")
        sig[base] = s
    t0 = max(0.0, max(float(s.time[0]) for s in sig.values()))
    t1 = min(float(s.time[-1]) for s in sig.values())
    if t1 - t0 < 10 * dt:
        raise IdentificationError(f"{where}: the signals overlap for {t1 - t0:.1f} s only")
    t = t0 + dt * np.arange(int(np.floor((t1 - t0) / dt + 1e-9)) + 1)
    v = np.maximum(sig["veh_spd"].at(t), 0.0)
    ph, amb, clt = (test.best(b, ("test",)) for b in ("test_phase", "amb_temp",
                                                      "eng_temp_coolant"))
    tr = Trace(test_id=test.meta.test_id, cycle=test.meta.cycle or "", t=t, v=v,
               a=acceleration(v, dt), force=sig["veh_frc_in"].at(t),
               w_eng=np.maximum(sig["eng_spd_out"].at(t), 0.0), fuel=sig["fuel_rate"].at(t),
               phase=np.round(ph.at(t, "previous")) if ph is not None else np.ones_like(t),
               constants=dict(test.meta.constants or {}), test_fuel=resolve_fuel(test=test),
               amb_temp_c=float(np.nanmean(amb.values)) if amb is not None else float("nan"),
               coolant_start_c=_start_value(clt, t0), file=str(where))
    negative = negative_fuel_channel(tr)
    if negative:
        raise IdentificationError(negative)
    return tr


def _start_value(sig, t0: float, span_s: float = 5.0) -> float:
    """Median [signal unit] of ``sig`` over its first ``span_s`` from ``t0`` (NaN if none)."""
    if sig is None:
        return float("nan")
    vals = np.asarray(sig.values, float)[(sig.time >= t0) & (sig.time < t0 + span_s)]
    vals = vals[np.isfinite(vals)]
    return float(np.median(vals)) if vals.size else float("nan")
