"""Plausibility gates on the fuel signal: the fuel the engine can have burnt for its work.

Two checks, both errors on the measured fuel rate (the results stage withholds every fuel
figure computed from it, :mod:`vehval.results.gate`):

- **efficiency** (kind ``fuel_efficiency``): the work delivered over the fuel energy at high
  load, where an engine runs near its best efficiency. The brake efficiency (engine power
  ``eng_trq_out x eng_spd_out``, measured or calculated) must lie inside
  :data:`vehval.constants.BRAKE_EFFICIENCY_RANGE`; for a conventional vehicle the wheels'
  tank-to-wheel efficiency (``veh_frc_in x veh_spd``) inside that band times the driveline's
  :data:`DRIVELINE_EFFICIENCY_RANGE`. A wrong scale of the fuel channel (x2, x0.5), a volume
  rate declared as a mass rate or a wrong unit moves it out; the finding names the unit that
  brings it back (:mod:`vehval.qa.unit_hints`) or the round factor.
  High load: 5 s averages of the power at or above half its 99th percentile (the fuel meter's
  lag and the kinetic energy averaged out); on the ten Cruze diesel tests the wheels' figure
  is 0.19-0.29, on the virtual 2004 Prius the engine's 0.36-0.37.
- **response** (kind ``fuel_response``): the fuel reads zero, is missing (NaN) or stays
  exactly flat (stuck, clipped at a ceiling) while the engine delivers power, for more than
  :data:`RESPONSE_MIN_S`: positive wheel power for a conventional vehicle, positive engine
  power for a hybrid (whose engine may be off while the battery drives the wheels). A fuel
  cut on a deceleration has negative wheel power and is not flagged.

The whole-test tank-to-wheel band of :mod:`vehval.qa.crosscheck` (``unit_suspect``) runs
first; a fuel signal it flagged is not judged again here.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vehval.constants import BRAKE_EFFICIENCY_RANGE
from vehval.integrals import held_sum
from vehval.qa.findings import Finding, Kind, Severity, merge_runs, message_units, runs
from vehval.qa.unit_hints import fix_text, hint_sentence, probable_units
from vehval.test import Signal, Test, is_hybrid

#: Driveline efficiency at high load (gearbox, final drive, tyres on the rolls) [-].
DRIVELINE_EFFICIENCY_RANGE = (0.80, 1.0)
#: Averaging window of the powers [s] (meter lag, kinetic energy).
WINDOW_S = 5.0
#: High load: the averaged power at or above this share of its 99th percentile.
HIGH_LOAD_SHARE = 0.5
#: High-load time [s] and work [J] needed for a verdict.
MIN_HIGH_LOAD_S = 20.0
MIN_WORK_J = 1e5
#: Round factors a fuel channel's scale may be wrong by.
ROUND_FACTORS = (2.0, 0.5, 10.0, 0.1, 4.0, 0.25, 5.0, 0.2, 3.0, 1 / 3, 100.0, 0.01, 1000.0, 0.001)
#: Power [W] above which the engine delivers, and the time [s] a fuel dropout must last.
DELIVER_MIN_W = 2000.0
RESPONSE_MIN_S = 5.0
#: Dropouts closer than this [s] are one.
MERGE_S = 2.0
#: A flat stretch counts only where the power varies by at least this [W] (peak to peak).
FLAT_POWER_SPAN_W = 3000.0


def _smooth(y: np.ndarray, n: int) -> np.ndarray:
    y = np.nan_to_num(np.asarray(y, float))
    return np.convolve(y, np.ones(n) / n, mode="same") if n > 1 else y


def _power(test: Test, t: np.ndarray, hybrid: bool) -> tuple[np.ndarray | None, str, list[str]]:
    """Power delivered [W] on ``t``: the engine's when known, else the wheels' (a
    conventional vehicle only); which one, and the signals."""
    trq = test.best("eng_trq_out", ("test", "calc"))
    spd = test.best("eng_spd_out", ("test", "calc"))
    if trq is not None and spd is not None:
        return np.maximum(trq.at(t) * spd.at(t), 0.0), "engine", [trq.name, spd.name]
    if hybrid:
        return None, "", []
    frc = test.best("veh_frc_in", ("test",))
    vs = test.best("veh_spd", ("test",))
    if frc is None or vs is None:
        return None, "", []
    return np.maximum(frc.at(t) * vs.at(t), 0.0), "wheel", [frc.name, vs.name]


def _fuel(test: Test) -> Signal | None:
    fuel = test.best("fuel_rate", ("test",))
    if fuel is None or fuel.time.size < 10 or not fuel.raw_unit:
        return None
    return fuel


def _lhv(test: Test, template: Any, vehicle: Any) -> tuple[float | None, float | None]:
    from vehval.fuels import resolve_fuel

    fuel = resolve_fuel(template=template, test=test, vehicle=vehicle)
    if fuel is None:
        return None, None
    return fuel.density_kg_per_m3, fuel.lhv_j_per_kg


def _round_factor(stat: float, band: tuple[float, float]) -> float | None:
    """The round factor of the fuel values that puts ``stat`` (∝ 1 / fuel) nearest the
    band's middle, or None."""
    mid = math.sqrt(band[0] * band[1])
    fits = [f for f in ROUND_FACTORS if band[0] <= stat / f <= band[1]]
    return min(fits, key=lambda f: abs(math.log(stat / f / mid))) if fits else None


def efficiency_gate(test: Test, template: Any = None, vehicle: Any = None,
                    skip: frozenset[str] = frozenset(),
                    exclude: list[tuple[float, float]] | None = None) -> list[Finding]:
    """The high-load efficiency gate of the module docstring (at most one finding).

    Parameters
    ----------
    test : Test
        The aligned test (measured and ``_calc`` signals).
    template, vehicle : optional
        For the fuel's heating value and density, and the architecture.
    skip : set of str
        Signals already flagged for their unit: not judged again.
    exclude : list of (float, float), optional
        Spans [s] left out (where the fuel does not follow the power: their own finding).
    """
    fuel = _fuel(test)
    if fuel is None or fuel.name in skip:
        return []
    density, lhv = _lhv(test, template, vehicle)
    if not lhv:
        return []
    t = np.asarray(fuel.time, float)
    hybrid = is_hybrid(test, vehicle)
    power, where, related = _power(test, t, hybrid)
    if power is None or any(r in skip for r in related):
        return []
    n = max(1, int(round(WINDOW_S / float(np.median(np.diff(t))))))
    p = _smooth(power, n)
    top = float(np.percentile(p, 99))
    sel = p >= HIGH_LOAD_SHARE * top
    for a, b in exclude or ():
        sel &= ~((t >= a - WINDOW_S) & (t <= b + WINDOW_S))
    dt = float(np.median(np.diff(t)))
    work = held_sum(p, dt, sel)
    if top <= 0 or sel.sum() * dt < MIN_HIGH_LOAD_S or work < MIN_WORK_J:
        return []
    lo, hi = BRAKE_EFFICIENCY_RANGE
    if where == "wheel":
        lo, hi = lo * DRIVELINE_EFFICIENCY_RANGE[0], hi * DRIVELINE_EFFICIENCY_RANGE[1]

    def eff(vals: np.ndarray) -> float:
        e = held_sum(_smooth(np.maximum(vals, 0.0), n), dt, sel) * float(lhv)
        return work / e if e > 0 else float("inf")

    s0 = eff(np.asarray(fuel.values, float))
    if not math.isfinite(s0) or lo <= s0 <= hi:
        return []
    what = ("brake efficiency (engine work over fuel energy)" if where == "engine"
            else "tank-to-wheel efficiency (wheel work over fuel energy)")
    hints = probable_units(fuel, eff, (lo, hi), density=density)
    numbers = {"efficiency": s0, "band": [lo, hi], "power": where,
               "high_load_s": float(sel.sum() * dt), "work_j": work,
               "high_load_power_w": HIGH_LOAD_SHARE * top, "declared_unit": fuel.raw_unit}
    head = (f"{fuel.name}: the {what} at high load (above {HIGH_LOAD_SHARE * top / 1e3:.1f} kW, "
            f"{sel.sum() * dt:.0f} s) is {100 * s0:.1f} %, outside the {100 * lo:.0f}-"
            f"{100 * hi:.0f} % a {'hybrid' if hybrid else 'car'}'s engine can give "
            f"({'engine' if where == 'engine' else 'wheels'}: {', '.join(related)})")
    if hints:
        best = hints[0]
        numbers.update(probable_unit=best.unit, factor=best.factor)
        msg, fix = f"{head}: {hint_sentence(fuel, hints)}", fix_text(fuel, best)
    else:
        f = _round_factor(s0, (lo, hi))
        if f is None:
            return []
        numbers["factor"] = 1.0 / f
        times = f"{1 / f:.4g}x" if f < 1 else f"1/{f:.4g}"
        msg = (f"{head}: the fuel reads about {times} the fuel this work needs (a scale or "
               f"calibration factor of {1 / f:.4g} on the channel?)")
        fix = (f"check {fuel.raw_name or fuel.name} ({fuel.name}): its scale, calibration "
               f"or unit; multiplied by {f:.4g} the efficiency is {100 * s0 / f:.1f} %")
    t0, t1 = float(t[0]), float(t[-1])
    return [Finding(fuel.name, Kind.FUEL_EFFICIENCY, t0, t1, Severity.ERROR, msg, numbers,
                    level=3, related=related, fix=fix)]


def _dropout_mask(v: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(zero, missing, flat) sample masks of the fuel rate ``v``: flat is a run of exactly
    repeated non-zero values lasting at least RESPONSE_MIN_S."""
    missing = ~np.isfinite(v)
    scale = float(np.nanpercentile(np.abs(v), 99)) if np.any(~missing) else 0.0
    zero = ~missing & (np.abs(v) <= 0.01 * scale)
    flat = np.zeros(v.size, bool)
    # runs of one exactly repeated value: a new run starts wherever the value changes
    starts = np.flatnonzero(np.concatenate(([True], np.diff(v) != 0)))
    ends = np.concatenate((starts[1:] - 1, [v.size - 1]))
    for i0, i1 in zip(starts.tolist(), ends.tolist()):
        if i1 > i0 and not (zero[i0] or missing[i0]) and t[i1] - t[i0] >= RESPONSE_MIN_S:
            flat[i0:i1 + 1] = True
    return zero, missing, flat


def response_gate(test: Test, template: Any = None, vehicle: Any = None) -> list[Finding]:
    """Fuel zero, missing or flat while the engine delivers power (module docstring)."""
    fuel = _fuel(test)
    if fuel is None:
        return []
    t = np.asarray(fuel.time, float)
    v = np.asarray(fuel.values, float)
    if not np.any(np.nan_to_num(v) > 0):
        return []                          # never measured: the all-zero check says so
    power, where, related = _power(test, t, is_hybrid(test, vehicle))
    if power is None:
        return []
    deliver = np.nan_to_num(power) > DELIVER_MIN_W
    dt = float(np.median(np.diff(t)))
    out: list[Finding] = []
    for label, mask in zip(("reads zero", "is missing (NaN)", "stays exactly flat"),
                           _dropout_mask(v, t)):
        spans = merge_runs(runs(mask & deliver), t, MERGE_S)
        bad = []
        for i0, i1 in spans:
            p = power[i0:i1 + 1]
            on = float(np.count_nonzero(deliver[i0:i1 + 1])) * dt
            if on < RESPONSE_MIN_S:
                continue
            if label.startswith("stays") and float(np.ptp(p)) < FLAT_POWER_SPAN_W:
                continue                     # steady power: a flat fuel may be true
            bad.append((i0, i1, on, float(np.mean(p[deliver[i0:i1 + 1]]))))
        if bad:
            out.append(_response_finding(fuel, t, v, label, bad, where, related))
    return out


def _response_finding(fuel: Signal, t: np.ndarray, v: np.ndarray, label: str,
                      bad: list[tuple[int, int, float, float]], where: str,
                      related: list[str]) -> Finding:
    i0, i1 = bad[0][0], bad[-1][1]
    total = sum(b[2] for b in bad)
    longest = max(bad, key=lambda b: b[2])
    val = v[longest[0]]
    shown = message_units(fuel.name, fuel.unit)[0]
    level = f" at {shown(float(val))}" if label.startswith("stays") else ""
    ceiling = (label.startswith("stays") and len(bad) > 1
               and math.isclose(val, float(np.nanmax(v)), rel_tol=1e-9))
    what = "clipped at its ceiling" if ceiling else label
    msg = (f"{fuel.name} {what}{level} for {total:.0f} s in {len(bad)} stretch(es) while the "
           f"engine delivers power ({where} power {longest[3] / 1e3:.1f} kW on average over "
           f"the longest, {longest[2]:.0f} s from {t[longest[0]]:.1f} s; {', '.join(related)}): "
           "the fuel burnt there is not in the figures")
    fix = (f"check the fuel meter and the {fuel.raw_name or fuel.name} channel over "
           f"{t[i0]:.1f}-{t[i1]:.1f} s (range, ceiling, logging); state the fuel figures only "
           "from a test whose fuel follows the engine's power")
    return Finding(fuel.name, Kind.FUEL_RESPONSE, float(t[i0]), float(t[i1]), Severity.ERROR,
                   msg, {"duration_s": total, "runs": len(bad), "mean_power_w": longest[3],
                         "power": where, "value": None if not np.isfinite(val) else float(val),
                         "clipped": bool(ceiling)},
                   level=3, related=related, fix=fix)


def run_fuel_gates(test: Test, template: Any = None, vehicle: Any = None,
                   earlier: list[Finding] | None = None) -> list[Finding]:
    """Both gates. ``earlier`` findings of kind ``unit_suspect`` exempt their signals from
    the efficiency gate (the unit is named already), unless the fuel does not follow the
    power: a whole-test integral over a dropout names no unit, so such a finding on the fuel
    is demoted to info (changed in place) and the dropout's own error stands."""
    response = response_gate(test, template, vehicle)
    dropped = {f.signal for f in response}
    for f in earlier or ():
        if f.kind == Kind.UNIT_SUSPECT and f.signal in dropped and f.severity == Severity.ERROR:
            f.severity = Severity.INFO
            f.message += (" (not judged: the fuel does not follow the engine's power over part "
                          "of the test, see the fuel_response finding)")
    skip = frozenset(f.signal for f in earlier or () if f.kind == Kind.UNIT_SUSPECT
                     and f.severity == Severity.ERROR)
    spans = [(f.start_s, f.end_s) for f in response]
    return efficiency_gate(test, template, vehicle, skip, spans) + response
