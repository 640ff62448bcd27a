"""The test's own conditions for its simulation: speed trace, initial SOC, mass, road load.

A model is validated on what the test actually did, not on the nominal cycle: the driver
follows the measured vehicle speed, the battery starts at the measured SOC, and the body
uses the test mass and dyno coefficients the template declared (``meta.constants``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import ValidationError

from vehval.conditions import TestConditions
from vehval.cycles import Cycle
from vehval.errors import ConfigError, SignalError
from vehval.fuels import require, resolve_fuel
from vehval.test import Test
from vehval.validate.quantities import pick_signal
from vehval.vehicle import BLOCKS, Vehicle
from vehval.vehicle.base import block_with

#: Template constants -> vehicle parameters they override.
CONSTANT_OVERRIDES = {
    "test_mass_kg": "body.mass_kg",
    "road_load_a_n": "body.road_load_a_n",
    "road_load_b_n_per_mps": "body.road_load_b_n_per_mps",
    "road_load_c_n_per_mps2": "body.road_load_c_n_per_mps2",
}

def full_name(name: str) -> str:
    """Dotted parameter name; ``__`` stands for ``.`` and a bare name means ``controller.<name>``."""
    name = name.strip().replace("__", ".")
    return name if "." in name else f"controller.{name}"


def vehicle_variant(vehicle: Vehicle, overrides: dict[str, float]) -> Vehicle:
    """A copy of ``vehicle`` with dotted parameters replaced, each changed block re-validated.

    Cheaper than :meth:`Vehicle.with_overrides` (only the changed blocks are validated and
    the engine's best-efficiency line is reused unless an engine parameter changed).

    Raises
    ------
    ConfigError
        If a block rejects the new values.
    """
    by_blk: dict[str, dict[str, float]] = {}
    for k, v in overrides.items():
        blk, key = full_name(k).split(".", 1)
        if blk not in BLOCKS:
            raise ConfigError(f"parameter '{k}': unknown block '{blk}' (use one of {', '.join(BLOCKS)})")
        by_blk.setdefault(blk, {})[key] = v
    update = {}
    for blk, upd in by_blk.items():
        block = getattr(vehicle, blk)
        try:
            update[blk] = block_with(block, upd)
        except ValidationError as exc:
            raise ConfigError(f"invalid {blk} parameters {upd}: {exc.errors()[0]['msg']}") from None
    if "engine" not in update:
        vehicle.best_line  # computed once on the base, shared by its copies  # noqa: B018
    new = vehicle.model_copy(update=update)
    if "engine" in update:
        new.__dict__.pop("best_line", None)
    return new



#: Measured speeds down to this value [m/s] are sensor noise at standstill and set to 0.
NEGATIVE_SPEED_NOISE_MPS = 0.5


@dataclass
class Conditions:
    """What the simulation of one test runs on.

    Attributes
    ----------
    cycle : Cycle
        The measured speed trace, on the test's clock [s].
    soc_initial : float or None
        Measured initial SOC [-] (None: the test has no SOC; the vehicle's target is used).
    overrides : dict
        Dotted vehicle parameters from the template constants (mass, road load).
    fuel_density_kg_per_m3, fuel_lhv_j_per_kg : float
        Properties of ``fuel``.
    fuel : ResolvedFuel
        The test fuel for the comparison (:func:`vehval.fuels.resolve_fuel`: the template's
        ``fuel:``, else its constants, else the vehicle's).
    notes : list of str
        Everything that was adjusted (clipped speeds, clamped SOC...).
    """

    cycle: Cycle
    soc_initial: float | None
    overrides: dict[str, float]
    fuel_density_kg_per_m3: float
    fuel_lhv_j_per_kg: float
    notes: list[str] = field(default_factory=list)
    fuel: Any = None

    def to_dict(self) -> dict[str, Any]:
        return {"cycle": self.cycle.name, "t0_s": float(self.cycle.time_s[0]),
                "duration_s": self.cycle.duration_s, "distance_m": self.cycle.distance_m,
                "soc_initial": self.soc_initial, "overrides": dict(self.overrides),
                "fuel_density_kg_per_m3": self.fuel_density_kg_per_m3,
                "fuel_lhv_j_per_kg": self.fuel_lhv_j_per_kg, "notes": list(self.notes)}


def initial_soc(test: Test, window_s: float = 2.0) -> float | None:
    """Median of the measured SOC [-] over its first ``window_s`` [s] of valid samples."""
    sig = pick_signal(test, "ess_soc", "test")
    if sig is None:
        return None
    ok = np.isfinite(sig.values)
    if not ok.any():
        return None
    t, v = sig.time[ok], sig.values[ok]
    return float(np.median(v[t <= t[0] + window_s]))


def smooth_speed(t: np.ndarray, v: np.ndarray, cutoff_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-phase low-pass of a measured speed trace (optional driver-input smoothing).

    The trace is resampled linearly on a uniform grid at its median sample interval, filtered
    forward and backward (``scipy.signal.filtfilt``) with a 2nd-order Butterworth low-pass
    at ``cutoff_hz`` (zero phase shift, effective order 4, -6 dB at the cut-off), and
    negative undershoots at stops are set to 0.

    Parameters
    ----------
    t : ndarray
        Strictly increasing time [s].
    v : ndarray
        Speed [m/s].
    cutoff_hz : float
        Cut-off frequency [Hz]; must be below the trace's Nyquist frequency.

    Returns
    -------
    t_uniform : ndarray [s], v_smooth : ndarray [m/s]

    Raises
    ------
    ConfigError
        If the cut-off is not positive or not below the Nyquist frequency of the trace.
    """
    from scipy.signal import butter, filtfilt

    if not (cutoff_hz > 0 and np.isfinite(cutoff_hz)):
        raise ConfigError(f"speed smoothing cut-off must be a positive frequency in Hz, got {cutoff_hz!r}")
    step = float(np.median(np.diff(t)))
    nyq = 0.5 / step
    if not cutoff_hz < nyq:
        raise ConfigError(f"speed smoothing cut-off {cutoff_hz:g} Hz is not below the Nyquist "
                          f"frequency {nyq:g} Hz of the measured speed ({1 / step:g} Hz samples): "
                          "use a lower cut-off or no smoothing")
    n = int(np.floor((t[-1] - t[0]) / step + 1e-9)) + 1
    tu = t[0] + step * np.arange(n)
    vu = np.interp(tu, t, v)
    b, a = butter(2, cutoff_hz / nyq)
    if vu.size <= 3 * max(a.size, b.size):  # too short for filtfilt's edge padding
        return tu, vu
    return tu, np.maximum(filtfilt(b, a, vu), 0.0)


def speed_trace(test: Test, smooth_hz: float | None = None) -> tuple[Cycle, list[str]]:
    """The measured vehicle speed as a :class:`Cycle` on the test's clock, with notes.

    ``smooth_hz`` (default None: the trace as measured) low-passes it first with
    :func:`smooth_speed` (zero phase, cut-off in Hz); see docs/validation.md for its effect.
    """
    sig = pick_signal(test, "veh_spd", "test")
    if sig is None:
        raise SignalError(f"test '{test.meta.test_id}': no measured vehicle speed (veh_spd_test): "
                          "the simulation follows the test's own speed trace")
    notes = []
    t, v = sig.time, sig.values
    ok = np.isfinite(t) & np.isfinite(v)
    if (~ok).sum():
        notes.append(f"{sig.name}: {(~ok).sum()} missing samples skipped (speed interpolated)")
    t, v = t[ok], v[ok]
    keep = np.concatenate([[True], np.diff(t) > 0]) if t.size else np.zeros(0, bool)
    while not keep.all():  # drop repeated / backward time stamps until time increases
        if (~keep).sum():
            notes.append(f"{sig.name}: {(~keep).sum()} non-increasing time stamps dropped")
        t, v = t[keep], v[keep]
        keep = np.concatenate([[True], np.diff(t) > 0])
    neg = v < 0
    if neg.any():
        big = v < -NEGATIVE_SPEED_NOISE_MPS
        notes.append(f"{sig.name}: {int(neg.sum())} negative samples set to 0"
                     + (f" (down to {v.min():.3g} m/s)" if big.any() else ""))
        v = np.maximum(v, 0.0)
    if smooth_hz is not None:
        t, v = smooth_speed(t, v, float(smooth_hz))
        notes.append(f"{sig.name}: low-passed for the driver (zero-phase 2nd-order Butterworth, "
                     f"cut-off {float(smooth_hz):g} Hz)")
    name = f"{test.meta.cycle or 'trace'}_measured"
    cyc = Cycle.from_trace(t, v, name, description=f"measured speed trace of {test.meta.test_id}",
                           source=f"{sig.name} of test {test.meta.test_id}")
    return cyc, notes


def simulation_conditions(test: Test, vehicle: Any, *, use_constants: bool = True,
                          smooth_hz: float | None = None) -> Conditions:
    """Gather the simulation conditions of ``test`` for ``vehicle``.

    Parameters
    ----------
    test : Test
        Validated test with ``veh_spd_test`` (and normally ``ess_soc_test``).
    vehicle : Vehicle
        The model (for its battery window and fuel properties).
    use_constants : bool
        Apply the template's mass and road-load constants as vehicle overrides.
    smooth_hz : float, optional
        Low-pass cut-off [Hz] of the measured speed given to the driver (default: none).
    """
    cyc, notes = speed_trace(test, smooth_hz)
    soc0 = initial_soc(test)
    bt = vehicle.battery
    if soc0 is None:
        notes.append("no measured SOC: the simulation starts at the controller's SOC target")
    elif not bt.soc_min <= soc0 <= bt.soc_max:
        clamped = min(max(soc0, bt.soc_min), bt.soc_max)
        notes.append(f"measured initial SOC {soc0:.4f} outside the model's window "
                     f"[{bt.soc_min:g}, {bt.soc_max:g}]: clamped to {clamped:.4f}")
        soc0 = clamped
    cond = TestConditions.resolve(test, None, vehicle)
    overrides = {}
    if use_constants:
        for key, path in CONSTANT_OVERRIDES.items():
            if (cond.source(key) or "").startswith("template"):
                overrides[path] = cond[key]
    fuel = resolve_fuel(test=test, vehicle=vehicle)
    return Conditions(cycle=cyc, soc_initial=soc0, overrides=overrides,
                      fuel_density_kg_per_m3=require(fuel, "density_kg_per_m3", "validation"),
                      fuel_lhv_j_per_kg=require(fuel, "lhv_j_per_kg", "validation"),
                      notes=notes, fuel=fuel)
