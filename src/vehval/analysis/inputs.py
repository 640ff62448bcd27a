"""Inputs of the control-strategy analysis: the signals it needs, on one uniform grid.

The analysis works on measured (``_test``) signals first and on calculated (``_calc``)
signals when nothing is measured. Every derived quantity records how it was obtained
(measured, computed from measured signals, or inferred from the speed trace and
constants), so the results can say what they rest on.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.integrals import battery_power
from vehval.nomenclature import registry
from vehval.test import Signal, Test

#: Origins searched, in order of preference.
ORIGINS = ("test", "calc")


@dataclass
class Finding:
    """A note about the data or the analysis (``kind``: info, warning, excluded)."""

    kind: str
    signal: str
    message: str
    count: int = 0

    def to_dict(self) -> dict:
        return {"kind": self.kind, "signal": self.signal, "message": self.message,
                "count": int(self.count)}


@dataclass
class AnalysisInputs:
    """Signals on a uniform grid (NaN where unknown) plus their provenance.

    Attributes
    ----------
    t : ndarray
        Time [s].
    dt : float
        Grid step [s].
    v : ndarray
        Vehicle speed [m/s].
    a : ndarray
        Vehicle acceleration [m/s²] (measured, or the smoothed derivative of ``v``).
    p_whl : ndarray
        Delivered wheel power [W] (> 0 propelling, < 0 braking).
    eng_spd, eng_trq, fuel_rate : ndarray
        Engine speed [rad/s], engine torque [N·m], fuel mass rate [kg/s].
    ess_curr, ess_volt, ess_pwr : ndarray
        Battery current [A] (> 0 discharging), voltage [V], power [W] (> 0 discharging).
    soc : ndarray
        Battery state of charge [-] (0..1).
    brk_frc : ndarray
        Friction brake force [N] (>= 0) when measured.
    consts : dict
        Constants used (test mass, road load, wheel radius...; SI, unit in the key).
    sources : dict
        Quantity -> how it was obtained (signal names or the formula used).
    """

    t: np.ndarray
    dt: float
    v: np.ndarray
    a: np.ndarray
    p_whl: np.ndarray
    eng_spd: np.ndarray
    eng_trq: np.ndarray
    fuel_rate: np.ndarray
    ess_curr: np.ndarray
    ess_volt: np.ndarray
    ess_pwr: np.ndarray
    soc: np.ndarray
    brk_frc: np.ndarray
    mass_kg: float | None = None
    consts: dict[str, float] = field(default_factory=dict)
    sources: dict[str, str] = field(default_factory=dict)
    findings: list[Finding] = field(default_factory=list)

    @property
    def n(self) -> int:
        return int(self.t.size)

    def has(self, name: str) -> bool:
        """True when quantity ``name`` has at least one finite sample."""
        return bool(np.any(np.isfinite(getattr(self, name))))


def pick_signal(test: Test, base: str) -> Signal | None:
    """The signal of a base name the analysis uses: measured before calculated, then the
    most trusted source (:meth:`vehval.test.Test.best`); ``None`` when the test has none."""
    return test.best(base, ORIGINS)


def _constants(test: Test, vehicle: Any, constants: dict | None) -> dict[str, float]:
    """Mass, road load, wheel radius... (:class:`vehval.conditions.TestConditions`: explicit
    argument > template constants > vehicle file), plus the test's other constants."""
    from vehval.conditions import TestConditions

    cond = TestConditions.resolve(test, None, vehicle, constants)
    out = {k: v for k, v in cond.as_dict().items() if cond.source(k) != "default"}
    for src in (test.meta.constants or {}, constants or {}):
        out.update({k: float(v) for k, v in src.items() if v is not None and k not in out})
    return out


def _smooth_derivative(t: np.ndarray, v: np.ndarray, window_s: float = 1.0) -> np.ndarray:
    """Central-difference derivative of ``v`` after a moving-average of ``window_s`` [s]."""
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    k = max(1, round(window_s / dt))
    vv = np.where(np.isfinite(v), v, np.nan)
    if k > 1:
        ker = np.ones(k) / k
        filled = np.nan_to_num(vv)
        num = np.convolve(filled, ker, mode="same")
        den = np.convolve(np.isfinite(vv).astype(float), ker, mode="same")
        vv = np.where(den > 0.5, num / np.maximum(den, 1e-12), np.nan)
    return np.gradient(vv, t) if t.size > 1 else np.zeros_like(vv)


def _invalid_findings(sig: Signal, quantity: str) -> list[Finding]:
    """Findings for samples the importer excluded (invalid sentinel values -> NaN)."""
    out = []
    for note in sig.notes:
        if "invalid value" in note:
            count = 0
            head = note.split(" ", 1)[0]
            if head.isdigit():
                count = int(head)
            out.append(Finding("excluded", sig.name,
                               f"{quantity}: {note} (excluded from the analysis)", count))
    return out


def _sentinel_scan(sig: Signal, quantity: str, values: np.ndarray) -> tuple[np.ndarray, list[Finding]]:
    """Exclude repeated out-of-range sentinel values the template did not declare.

    A value is treated as a sentinel when it lies outside the registry's plausible range for
    the signal and occurs at least twice with exactly the same value (a stuck code, e.g.
    -327.68 A or 118.5 %), or once at an extreme beyond 1.5x the range.
    """
    from vehval.nomenclature import registry

    try:
        lo, hi = registry().spec_of(sig.name).range
    except Exception:  # noqa: BLE001 - unknown base: nothing to scan against
        return values, []
    bad = np.isfinite(values) & ((values < lo) | (values > hi))
    if not np.any(bad):
        return values, []
    vals, counts = np.unique(values[bad], return_counts=True)
    codes = [float(x) for x, c in zip(vals, counts) if c >= 2 or abs(x) > 1.5 * max(abs(lo), abs(hi))]
    out = values.copy()
    findings = []
    for c in codes:
        m = values == c
        out[m] = np.nan
        findings.append(Finding("excluded", sig.name,
                                f"{quantity}: {int(m.sum())} sample(s) at {c:g} {sig.unit}, outside "
                                f"the plausible range [{lo:g}, {hi:g}], treated as an invalid "
                                "sentinel value and excluded", int(m.sum())))
    return out, findings


def prepare_inputs(test: Test, vehicle: Any = None, constants: dict | None = None,
                   dt: float | None = None) -> AnalysisInputs:
    """Collect the analysis signals of ``test`` on one uniform grid.

    Parameters
    ----------
    test : Test
        Imported (and ideally QA-validated) test.
    vehicle : Vehicle, optional
        Supplies mass, road load and wheel radius when the test constants lack them.
    constants : dict, optional
        Constants overriding the test's (``test_mass_kg``, ``road_load_a_n``, ...).
    dt : float, optional
        Grid step [s]; default: the vehicle speed signal's median period, at least 0.1 s.

    Returns
    -------
    AnalysisInputs

    Raises
    ------
    SignalError
        When the test has no vehicle speed signal.
    """
    from vehval.errors import SignalError

    spd = pick_signal(test, "veh_spd")
    if spd is None:
        raise SignalError(f"test '{test.meta.test_id}': the control-strategy analysis needs a "
                          "vehicle speed signal (veh_spd_*_test); map one in the template")
    step = float(dt) if dt else max(0.1, round(spd.sample_period, 3))
    t0, t1 = float(np.nanmin(spd.time)), float(np.nanmax(spd.time))
    n = int(np.floor((t1 - t0) / step + 1e-9)) + 1
    t = t0 + step * np.arange(n)
    consts = _constants(test, vehicle, constants)
    findings: list[Finding] = []
    sources: dict[str, str] = {}
    nan = np.full(n, np.nan)

    def grab(base: str, quantity: str) -> np.ndarray:
        sig = pick_signal(test, base)
        if sig is None:
            return nan.copy()
        findings.extend(_invalid_findings(sig, quantity))
        vals, f2 = _sentinel_scan(sig, quantity, sig.values)
        findings.extend(f2)
        sources[quantity] = sig.name
        return Signal(sig.name, sig.time, vals, sig.unit, resample=sig.resample).at(t)

    v = grab("veh_spd", "vehicle speed")
    v = np.where(np.isfinite(v), np.maximum(v, 0.0), v)
    a = grab("veh_acc", "acceleration")
    if not np.any(np.isfinite(a)):
        a = _smooth_derivative(t, v)
        sources["acceleration"] = f"d/dt of {sources['vehicle speed']} (1 s moving average)"
    eng_spd = grab("eng_spd_out", "engine speed")
    eng_trq = grab("eng_trq_out", "engine torque")
    fuel = grab("fuel_rate", "fuel rate")
    curr = grab("ess_curr", "battery current")
    volt = grab("ess_volt", "battery voltage")
    soc = grab("ess_soc", "state of charge")
    brk = grab("brk_frc", "friction brake force")
    pwr = grab("ess_pwr", "battery power")
    if not np.any(np.isfinite(pwr)) and np.any(np.isfinite(curr)) and np.any(np.isfinite(volt)):
        pwr = battery_power(volt, curr)
        sources["battery power"] = f"{sources['battery current']} x {sources['battery voltage']}"

    # delivered wheel power, most direct first (the driver's demand is not measured: the
    # rule's demand is rebuilt from these by vehval.analysis.demand)
    p_whl = nan.copy()
    frc = pick_signal(test, "veh_frc_in")
    if frc is not None:
        p_whl = grab("veh_frc_in", "tractive force") * v
        sources["wheel power"] = f"{frc.name} x {sources['vehicle speed']} (measured)"
    if not np.any(np.isfinite(p_whl)) and pick_signal(test, "whl_pwr_out") is not None:
        p_whl = grab("whl_pwr_out", "wheel power")
        sources["wheel power"] = sources["wheel power"] + " (signal)"
    if not np.any(np.isfinite(p_whl)) and pick_signal(test, "whl_trq_out") is not None:
        trq = grab("whl_trq_out", "wheel torque")
        wsp = grab("whl_spd", "wheel speed")
        if np.any(np.isfinite(wsp)):
            p_whl = trq * wsp
            sources["wheel power"] = f"{sources['wheel torque']} x {sources['wheel speed']}"
        elif consts.get("wheel_radius_m"):
            p_whl = trq * v / consts["wheel_radius_m"]
            sources["wheel power"] = (f"{sources['wheel torque']} x vehicle speed / wheel radius "
                                      f"{consts['wheel_radius_m']:g} m")
    mass = consts.get("test_mass_kg")
    if not np.any(np.isfinite(p_whl)) and mass:
        fa = consts.get("road_load_a_n", 0.0)
        fb = consts.get("road_load_b_n_per_mps", 0.0)
        fc = consts.get("road_load_c_n_per_mps2", 0.0)
        infl = 1.0 + consts.get("inertia_fraction", 0.0)
        road = np.where(v > 0.05, fa + fb * v + fc * v * v, 0.0)
        p_whl = (mass * infl * a + road) * v
        sources["wheel power"] = (f"inferred: (m·a + A + B·v + C·v²)·v with m = {mass:g} kg, "
                                  f"A = {fa:g} N, B = {fb:g} N/(m/s), C = {fc:g} N/(m/s)² "
                                  "(no measured force or torque; grade and wind ignored)")
        if not any(k in consts for k in ("road_load_a_n", "road_load_c_n_per_mps2")):
            findings.append(Finding("warning", "wheel power",
                                    "no road-load constants: wheel power demand is inertial only"))
    if not np.any(np.isfinite(p_whl)):
        findings.append(Finding("warning", "wheel power",
                                "no tractive force, wheel torque or test mass: wheel power demand "
                                "unknown; power thresholds and operating modes that need it are "
                                "not estimated"))
    return AnalysisInputs(t=t, dt=step, v=v, a=a, p_whl=p_whl, eng_spd=eng_spd, eng_trq=eng_trq,
                          fuel_rate=fuel, ess_curr=curr, ess_volt=volt, ess_pwr=pwr, soc=soc,
                          brk_frc=brk, mass_kg=mass, consts=consts, sources=sources,
                          findings=findings)


#: Simulator-internal signals a test cannot record (left out by :func:`from_simulation`).
SIMULATOR_INTERNAL = ("drv_pwr_demand", "drv_frc_demand", "eng_ctrl_state", "ess_pwr_lim_state")


def from_simulation(sim_test: Test) -> Test:
    """A copy of a simulation's test with every ``_simu`` signal renamed ``_test``.

    Lets the analysis run on a simulation as if it were a measurement (e.g. to compare a
    model's strategy with a test's). The controller's internal signals
    (:data:`SIMULATOR_INTERNAL`: driver demand, controller state) are left out, as no test
    records them. For a realistic check use the virtual dyno's files
    (:func:`vehval.synth.make_virtual_test`), which add sensor lags, noise and offsets.
    """
    out = Test(meta=sim_test.meta)
    for sig in sim_test:
        if sig.name.endswith("_simu") and sig.name[: -len("_simu")] not in SIMULATOR_INTERNAL:
            name = sig.name[: -len("_simu")] + "_test"
            out.add(Signal(name, sig.time, sig.values, sig.unit, source="",
                           resample=sig.resample, notes=list(sig.notes)))
    return out


#: Quantities the analysis checks itself against the SOC trend (sign, bias): when QA
#: dropped them for their sign only, the analysis may still use them.
SIGN_CHECKED = ("ess_curr", "ess_pwr")


def after_qa(qa_result: Any, imported: Test) -> tuple[Test, list[str]]:
    """The test the analysis runs on once QA ran, and notes on what was taken back.

    QA's validated test (not modified), plus the battery signals QA dropped only for a
    reversed sign (see :func:`restore_sign_checked`).
    """
    validated = qa_result.validated
    test = Test(list(validated), meta=copy.deepcopy(validated.meta))
    return test, restore_sign_checked(test, imported, qa_result.selection.dropped)


#: Bases whose samples QA flagged are not used by the analysis, and the per-sample kinds.
MASKED_BASES = ("ess_soc",)
MASKED_KINDS = ("range", "spike", "negative", "vehicle_limit", "stuck")


def mask_flagged_samples(test: Test, findings: list) -> list[Finding]:
    """Set to NaN the SOC samples inside a QA warning/error of a per-sample kind (range,
    spike...): a SOC of 0 QA flagged must not become the analysis's minimum SOC. Modifies
    ``test`` in place; returns one ``excluded`` finding per signal changed."""
    from vehval.qa.findings import untrusted_mask

    per_sample = [f for f in findings if str(getattr(f.kind, "value", f.kind)) in MASKED_KINDS]
    out = []
    for base in MASKED_BASES:
        for sig in test.by_base(base, "test"):
            bad = untrusted_mask({sig.name}, sig.time, per_sample) & np.isfinite(sig.values)
            if not bad.any():
                continue
            test.add(dataclasses.replace(sig, values=np.where(bad, np.nan, sig.values)),
                     replace_existing=True)
            why = "; ".join(f.message for f in per_sample if f.signal == sig.name)
            out.append(Finding("excluded", sig.name, f"{int(bad.sum())} sample(s) QA flagged "
                               f"are not used ({why})", int(bad.sum())))
    return out


def restore_sign_checked(validated: Test, imported: Test, dropped: dict[str, str]) -> list[str]:
    """Put back battery current/power signals that QA dropped only for a reversed sign.

    The analysis estimates the battery's sign convention itself from the SOC trend, so a
    signal dropped for ``sign_flip`` is still usable there. It is taken from ``imported``,
    shifted by the offset QA applied to its source, and added to ``validated`` only when no
    signal of that quantity is left. Returns one note per restored signal.

    Parameters
    ----------
    validated : Test
        QA's validated test (modified in place).
    imported : Test
        The test as imported, before alignment.
    dropped : dict
        QA's selection ``dropped`` mapping (full name -> reason).
    """
    notes = []
    reg = registry()
    for name, reason in sorted(dropped.items()):
        if not reason.startswith("sign_flip") or name not in imported:
            continue
        base = reg.parse(name).base
        if base not in SIGN_CHECKED or validated.by_base(base, None):
            continue
        sig = imported[name]
        offset = validated.meta.offsets_s.get(sig.source, 0.0)
        validated.add(sig.shifted(offset) if offset else sig)
        notes.append(f"{name}: used although QA dropped it for its sign; the analysis checks "
                     "the sign against the SOC trend")
    return notes
