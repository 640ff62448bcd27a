"""Physical cross-checks that catch unit and mapping mistakes in a template.

A unit mistake passes every per-signal check (smooth, in range, self-consistent) yet changes
every result. Each check below computes one whole-test statistic that physics bounds, and
when the statistic is impossible as declared it names the unit that makes it possible
(:mod:`vehval.qa.unit_hints`), as a ``unit_suspect`` finding with its one-line ``fix``:

- **fuel energy against tractive energy**: positive wheel energy over fuel energy (a whole
  test's tank-to-wheel efficiency) in 4..45 %; without a force signal, the fuel energy per
  distance in 0.5..15 MJ/km;
- **speed trace against the drive cycle**: the measured speed follows no known cycle as
  declared but does in another speed unit (km/h, mph, m/s), or another channel of its
  file does (swapped mappings); with no cycle at all, the top speed in 5..70 m/s; its
  distance over the cycle's runs within 2 % of the cycle's, also when it follows a cycle
  only once divided by a factor (a speed scale, :mod:`vehval.qa.speed_scale`);
- **force against mass x acceleration**: the measured tractive force regressed on
  ``m·a`` and a free road-load polynomial; a gain of 0.454 names a test mass written in lb,
  4.448 a force in lbf;
- **engine speed**: the median running speed in 500..4500 rpm (rpm against rad/s);
- **temperatures**: ambient in -45..60 °C, coolant at most 135 °C and, after 15 min of a
  running engine, at least 45 °C (degC, degF, K);
- **pressures**: ambient 60..110 kPa, intake manifold 15..250 kPa (Pa, hPa, kPa, bar, psi);
- **phase channel**: whole numbers, few values, few changes (a wrong channel mapped as
  the phase counter);
- **file header against template**: a unit the template declares over the file header's
  own when no physics check can tell which of the two is right;
- **OBD speed** (:mod:`vehval.qa.obd_checks`): whole-numbered raw speeds of an OBD source
  declared in mph or m/s are SAE J1979's whole km/h.

A check raises an **error** when the physics make the signal impossible as declared, and a
**warning** when it is only suspicious (the header conflict on a signal no result depends
on). All checks are whole-test integrals or percentiles: cheap next to the QA levels.
"""

from __future__ import annotations

import functools
import math
from typing import Any, Callable

import numpy as np

from vehval.constants import RPM_RAD_PER_S
from vehval.display import percent
from vehval.equations.engine_state import engine_running
from vehval.integrals import integral as _integral
from vehval.qa.findings import Finding, Kind, Severity
from vehval.qa.unit_hints import (
    UnitHint,
    factor,
    fix_text,
    fmt_factor,
    header_unit,
    hint_sentence,
    probable_units,
    reinterpret,
)
from vehval.test import Signal, Test

#: Whole-test tank-to-wheel efficiency a car can show (positive wheel energy / fuel energy):
#: at most the best engine's peak efficiency (about 45 %, a modern diesel); measured 13-22 %
#: on the Cruze diesel cycles, about 30 % on a virtual 2004 Prius.
EFFICIENCY_BAND = (0.04, 0.45)
#: Fuel energy per distance [J/m] when no force is measured: 0.5 MJ/km is below the best
#: hybrid's lab figure (about 2.5 L/100 km of gasoline = 0.8 MJ/km), 15 MJ/km beyond a heavy
#: SUV on US06.
ENERGY_PER_DISTANCE_BAND = (500.0, 15000.0)
#: Gain of the measured force over ``m·a`` (a chassis dyno simulates the test mass; the
#: rotating inertia adds a few %).
MASS_GAIN_BAND = (0.85, 1.2)
#: Median running engine speed [rad/s] (500..4500 rpm).
ENGINE_SPEED_BAND = (500 * RPM_RAD_PER_S, 4500 * RPM_RAD_PER_S)
#: Median ambient temperature [degC] and the coolant's maximum [degC].
AMBIENT_TEMP_BAND = (-45.0, 60.0)
COOLANT_MAX_BAND = (-45.0, 135.0)
COOLANT_WARM_BAND = (45.0, 135.0)
#: Where a candidate reading is most likely (the test-cell standard, a thermostat) [degC]:
#: ranks two units that both fit.
AMBIENT_TEMP_TYPICAL = 22.0
COOLANT_TYPICAL = 90.0
#: Engine running time [s] after which the coolant must have warmed past 45 degC.
WARM_UP_S = 900.0
#: Median ambient pressure and intake manifold pressure [Pa].
AMBIENT_PRES_BAND = (60e3, 110e3)
INTAKE_PRES_BAND = (15e3, 250e3)
#: Base names whose headline figures depend on the signal (a header conflict is an error).
FIGURE_BASES = ("fuel_rate", "veh_spd")
LB_KG = 0.45359237
#: Top speed [m/s] (99.9th percentile) of a test that drives a car at all, on a dyno or a road.
SPEED_TOP_BAND = (5.0, 70.0)
#: Relative difference of a trace's top speed from a cycle's it can follow.
CYCLE_TOP_TOL = 0.15
#: A phase channel counts phases: at most this many distinct values and changes.
PHASE_MAX_VALUES = 40
PHASE_MAX_CHANGES = 200


class _Verdicts:
    """Which signals a check judged, to settle a header conflict."""

    def __init__(self) -> None:
        self.ok: set[str] = set()          # declared unit fits, header's (if any) does not
        self.flagged: set[str] = set()     # a finding was made


def _span(test: Test) -> tuple[float, float]:
    t0, t1 = test.span()
    return float(t0), float(t1)


def _values_at(sig: Signal, t: np.ndarray) -> np.ndarray:
    """``sig`` at times ``t`` [s], without resampling when it is sampled there already."""
    if sig.time.shape == t.shape and np.array_equal(sig.time, t):
        return np.asarray(sig.values, float)
    return sig.at(t)


def _judge(test: Test, sig: Signal, stat: Callable[[np.ndarray], float],
           band: tuple[float, float], verdicts: _Verdicts, what: str, *,
           density: float | None = None, numbers: dict | None = None,
           related: list[str] | None = None, center: float | None = None) -> list[Finding]:
    """One finding when ``stat`` of ``sig`` is outside ``band`` as declared and inside
    it in another unit; records the verdict for the header check."""
    if not sig.raw_unit:
        return []
    s0 = stat(np.asarray(sig.values, float))
    if not math.isfinite(s0):
        return []
    lo, hi = band
    hdr = header_unit(sig)
    if lo <= s0 <= hi:
        vals = reinterpret(sig, hdr, density) if hdr else None
        if hdr is None or vals is None or not (lo <= stat(vals) <= hi):
            verdicts.ok.add(sig.name)
        return []
    hints = probable_units(sig, stat, band, density=density, center=center)
    if not hints:
        return []
    verdicts.flagged.add(sig.name)
    t0, t1 = _span(test)
    best: UnitHint = hints[0]
    return [Finding(
        sig.name, Kind.UNIT_SUSPECT, t0, t1, Severity.ERROR,
        f"{sig.name}: {what} is {s0:.4g} as declared, outside {lo:.4g}..{hi:.4g}, and "
        f"{best.value:.4g} read in {best.unit}: {hint_sentence(sig, hints)}",
        {"statistic": s0, "band": [lo, hi], "factor": best.factor, "probable_unit": best.unit,
         "declared_unit": sig.raw_unit, "alternatives": [h.unit for h in hints[1:]],
         **(numbers or {})},
        level=3, related=list(related or []), fix=fix_text(sig, best))]


def _fuel_density(template: Any, test: Test, vehicle: Any) -> tuple[float | None, float | None]:
    from vehval.fuels import resolve_fuel

    fuel = resolve_fuel(template=template, test=test, vehicle=vehicle)
    if fuel is None:
        return None, None
    return fuel.density_kg_per_m3, fuel.lhv_j_per_kg


def fuel_energy_check(test: Test, template: Any, vehicle: Any, verdicts: _Verdicts
                      ) -> list[Finding]:
    """Fuel energy against tractive energy over the whole test (or per distance)."""
    fuel = test.best("fuel_rate", ("test",))
    spd = test.best("veh_spd", ("test",))
    if fuel is None or spd is None or spd.name in verdicts.flagged:
        return []
    density, lhv = _fuel_density(template, test, vehicle)
    if not lhv:
        return []
    tf = np.asarray(fuel.time, float)

    def fuel_j(vals: np.ndarray) -> float:
        return _integral(tf, np.maximum(np.nan_to_num(vals, nan=0.0), 0.0)) * float(lhv)

    frc = test.best("veh_frc_in", ("test",))
    if frc is not None and frc.name not in verdicts.flagged:
        t = np.asarray(frc.time, float)
        e_wheel = _integral(t, np.maximum(np.asarray(frc.values, float) * _values_at(spd, t), 0.0))
        source = f"{frc.name} x {spd.name}"
        related = [frc.name, spd.name]
    else:
        e_wheel, source, related = float("nan"), "", [spd.name]
    if math.isfinite(e_wheel) and e_wheel > 1e4:
        def eff(vals: np.ndarray) -> float:
            e = fuel_j(vals)
            return e_wheel / e if e > 0 else float("inf")
        out = _judge(test, fuel, eff, EFFICIENCY_BAND, verdicts,
                     f"the tank-to-wheel efficiency ({e_wheel / 1e6:.3g} MJ at the wheels "
                     f"from {source} over the fuel energy)", density=density,
                     numbers={"wheel_energy_j": e_wheel}, related=related)
        for f in out:
            f.numbers["efficiency"] = f.numbers["statistic"]
        return out
    ts = np.asarray(spd.time, float)
    dist = _integral(ts, np.abs(np.nan_to_num(np.asarray(spd.values, float))))
    if not (math.isfinite(dist) and dist > 1000.0):
        return []

    def per_m(vals: np.ndarray) -> float:
        return fuel_j(vals) / dist
    return _judge(test, fuel, per_m, ENERGY_PER_DISTANCE_BAND, verdicts,
                  f"the fuel energy per distance [J/m] over {dist / 1000:.3g} km",
                  density=density, numbers={"distance_m": dist}, related=related)


def speed_cycle_check(test: Test, verdicts: _Verdicts, density: float | None = None
                      ) -> list[Finding]:
    """The speed trace against the drive cycles, in each speed unit, then the other
    channels of its file read as a speed (a swapped mapping; ``density`` [kg/m³] reads a
    volumetric fuel flow back to its raw numbers)."""
    sig = test.best("veh_spd", ("test",))
    if sig is None or not sig.raw_unit:
        return []
    v = np.asarray(sig.values, float)
    if not np.any(np.nan_to_num(v) > 1.0):
        return []
    match = test.meta.cycle_match or {}
    if match.get("name") and match.get("signal") == sig.name and match.get("method") == "cycle":
        verdicts.ok.add(sig.name)                 # follows its cycle as declared
        return []
    from vehval.cycles import list_cycles
    from vehval.cycles_match import identify_cycle

    base = (test.meta.cycle or "").split("_x")[0] if match.get("method") != "steady" else ""
    cycles = [base] if base and base in list_cycles() else None
    found: dict[float, str] = {}               # cycle found, by the trace's top speed
    declared_tried = match.get("signal") == sig.name and not base   # import identified it

    def follows(vals: np.ndarray) -> float:
        if declared_tried and vals is v:
            return 0.0
        near = cycles_near(vals, cycles)
        if not near:
            return 0.0
        name, _score, details = identify_cycle(sig.time, vals, cycles=near)
        if name and details.get("method") == "cycle":
            found[round(float(np.nanmax(vals)), 6)] = name
            return 1.0
        return 0.0
    out = _judge(test, sig, follows, (0.5, 1.5), verdicts,
                 "the match to a drive cycle (1 = follows one)")
    for f in out:
        best = reinterpret(sig, f.numbers["probable_unit"])
        key = round(float(np.nanmax(best)), 6) if best is not None else None
        cyc = found.get(key, "a cycle") if key is not None else "a cycle"
        f.message = (f"{sig.name} follows no known drive cycle as declared but follows {cyc} "
                     f"read in {f.numbers['probable_unit']}: "
                     + f.message.split(": ", 2)[-1])
        f.numbers["cycle"] = cyc
    top = _top(v)
    if not out and sig.name not in verdicts.ok and not SPEED_TOP_BAND[0] <= top <= SPEED_TOP_BAND[1]:
        # no car's speed: perhaps another channel's numbers (searched only then: it costs)
        out = _swapped_speed(test, sig, cycles, verdicts, density)
        if not out:                     # no cycle anywhere: at least a car's top speed
            out = _judge(test, sig, _top, SPEED_TOP_BAND, verdicts,
                         "the top speed [m/s] (99.9th percentile)")
    return out


@functools.lru_cache(maxsize=1)
def _cycle_tops() -> dict[str, float]:
    from vehval.cycles import list_cycles, load_cycle

    return {n: float(np.max(load_cycle(n).speed_mps)) for n in list_cycles()}


def cycles_near(speed_mps: np.ndarray, cycles: list[str] | None = None) -> list[str]:
    """Package cycles whose top speed is within ``CYCLE_TOP_TOL`` of the trace's (99.9th
    percentile): the only ones it can follow (a cheap filter before the identification)."""
    v = np.asarray(speed_mps, float)
    v = v[np.isfinite(v)]
    if v.size < 10:
        return []
    top = float(np.percentile(v, 99.9))
    if not top > 1.0:
        return []
    tops = _cycle_tops()
    names = cycles if cycles is not None else list(tops)
    return [n for n in names if n in tops and abs(top / tops[n] - 1.0) <= CYCLE_TOP_TOL]


def _top(vals: np.ndarray) -> float:
    v = vals[np.isfinite(vals)]
    return float(np.percentile(v, 99.9)) if v.size >= 10 else float("nan")


def _swapped_speed(test: Test, sig: Signal, cycles: list[str] | None, verdicts: _Verdicts,
                   density: float | None) -> list[Finding]:
    """Another channel of the speed's file that follows a cycle read as a speed: the
    template probably swapped the two mappings."""
    from vehval.cycles_match import identify_cycle
    from vehval.units import conversion

    for other in test:
        if other is sig or other.file != sig.file or not other.raw_unit \
                or other.name.startswith("veh_spd"):
            continue
        try:
            scale, off = conversion(other.raw_unit, other.unit,
                                    fuel_density_kg_per_m3=density or 1000.0)
        except Exception:  # noqa: BLE001 - a unit that does not convert back is skipped
            continue
        if not scale:
            continue
        raw = (np.asarray(other.values, float) - off) / scale
        for unit in ("mph", "km/h", "m/s"):
            v = raw * conversion(unit, "m/s")[0]
            near = cycles_near(v, cycles)
            if not near:
                continue
            name, _score, details = identify_cycle(other.time, v, cycles=near)
            if not (name and details.get("method") == "cycle"):
                continue
            verdicts.flagged.add(sig.name)
            t0, t1 = _span(test)
            return [Finding(
                sig.name, Kind.UNIT_SUSPECT, t0, t1, Severity.ERROR,
                f"{sig.name} (raw '{sig.raw_name}') follows no drive cycle in any speed unit, "
                f"but {other.name} (raw '{other.raw_name}') follows {name} read in {unit}: the "
                "template probably swapped the two channels",
                {"probable_channel": other.raw_name, "probable_unit": unit, "cycle": name},
                level=3, related=[other.name],
                fix=f"map '{other.raw_name}' to {sig.name} in {unit}, and '{sig.raw_name}' to "
                    f"what it measures (swapped with {other.name}?)")]
    return []


def _smooth(y: np.ndarray, n: int) -> np.ndarray:
    if n <= 1 or y.size < n:
        return y
    return np.convolve(y, np.ones(n) / n, mode="same")


def mass_gain(force: np.ndarray, time: np.ndarray, speed: np.ndarray, mass_kg: float) -> float:
    """Gain of the force over ``m·a`` fitted with a free road load ``c0 + c1·v + c2·v²``.

    Parameters
    ----------
    force : numpy.ndarray
        Measured tractive force [N].
    time : numpy.ndarray
        Sample times [s].
    speed : numpy.ndarray
        Vehicle speed [m/s] at ``time``.
    mass_kg : float
        Declared test mass [kg].

    Returns
    -------
    float
        The gain (1 for a consistent force, mass and speed), NaN when not measurable.
    """
    ok = np.isfinite(force) & np.isfinite(speed) & np.isfinite(time)
    if ok.sum() < 50 or not mass_kg > 0:
        return float("nan")
    t, f, v = time[ok], force[ok], speed[ok]
    dt = float(np.median(np.diff(t)))
    if not dt > 0:
        return float("nan")
    n = max(1, int(round(1.0 / dt)))                  # 1 s moving mean against sensor noise
    vs = _smooth(v, n)
    a = np.gradient(vs, t)
    use = (vs > 1.0) & (np.abs(a) > 0.1)
    use[:n] = use[-n:] = False                         # the moving mean's edges
    use[np.arange(use.size) % max(1, n // 2) != 0] = False   # 2 samples per second suffice
    if use.sum() < 30:
        return float("nan")
    x = np.column_stack([mass_kg * a[use], np.ones(use.sum()), vs[use], vs[use] ** 2])
    coef, *_ = np.linalg.lstsq(x, _smooth(f, n)[use], rcond=None)
    return float(coef[0])


def force_mass_check(test: Test, constants: dict, verdicts: _Verdicts) -> list[Finding]:
    """Tractive force against ``m·a``: a test mass in lb, a force in lbf or kN."""
    frc = test.best("veh_frc_in", ("test",))
    spd = test.best("veh_spd", ("test",))
    mass = constants.get("test_mass_kg")
    if frc is None or spd is None or spd.name in verdicts.flagged or not mass:
        return []
    try:
        mass = float(mass)
    except (TypeError, ValueError):
        return []
    t = np.asarray(frc.time, float)
    v = _values_at(spd, t)
    gain = mass_gain(np.asarray(frc.values, float), t, v, mass)
    lo, hi = MASS_GAIN_BAND
    if not math.isfinite(gain) or lo <= gain <= hi:
        if math.isfinite(gain):
            verdicts.ok.add(frc.name)
        return []
    t0, t1 = _span(test)
    if lo <= gain / LB_KG <= hi:                   # the mass is the lb number
        return [Finding(
            frc.name, Kind.UNIT_SUSPECT, t0, t1, Severity.ERROR,
            f"{frc.name} is {gain:.3g} x test_mass_kg x acceleration (fitted with a free "
            f"road load): test_mass_kg = {mass:g} is probably in lb ({mass * LB_KG:.5g} kg)",
            {"gain": gain, "factor": LB_KG, "declared_mass": mass,
             "probable_mass_kg": mass * LB_KG},
            level=3, related=[spd.name],
            fix=f"set test_mass_kg to {mass * LB_KG:.5g} (the value {mass:g} is in lb, x{LB_KG:.4g})")]
    if lo <= gain * LB_KG <= hi:                   # kg written where lb was converted twice
        return [Finding(
            frc.name, Kind.UNIT_SUSPECT, t0, t1, Severity.ERROR,
            f"{frc.name} is {gain:.3g} x test_mass_kg x acceleration: test_mass_kg = {mass:g} "
            f"is probably converted from lb twice ({mass / LB_KG:.5g} kg)",
            {"gain": gain, "factor": 1 / LB_KG, "declared_mass": mass},
            level=3, related=[spd.name],
            fix=f"set test_mass_kg to {mass / LB_KG:.5g} (x{1 / LB_KG:.4g})")]

    def gain_of(vals: np.ndarray) -> float:
        return mass_gain(vals, t, v, mass)
    return _judge(test, frc, gain_of, MASS_GAIN_BAND, verdicts,
                  "the gain of the force over test_mass_kg x acceleration",
                  related=[spd.name])


def _running_median(vals: np.ndarray) -> float:
    v = np.asarray(vals, float)
    v = v[np.isfinite(v)]
    if v.size < 20:
        return float("nan")
    top = float(np.percentile(v, 99))
    if not top > 0:
        return float("nan")
    run = v[v > 0.1 * top]
    return float(np.median(run)) if run.size >= 20 else float("nan")


def engine_speed_check(test: Test, verdicts: _Verdicts) -> list[Finding]:
    """Median running engine speed (rpm against rad/s)."""
    out: list[Finding] = []
    for sig in test:
        if sig.name.startswith("eng_spd_out") and sig.name.endswith("_test"):
            out += _judge(test, sig, _running_median, ENGINE_SPEED_BAND, verdicts,
                          "the median running engine speed [rad/s]")
    return out


def _engine_running_s(test: Test) -> float:
    sig = test.best("eng_spd_out", ("test",))
    if sig is None:
        return 0.0
    t = np.asarray(sig.time, float)
    v = np.asarray(sig.values, float)
    if t.size < 2:
        return 0.0
    dt = np.diff(t, append=t[-1])
    # running by the one engine-on rule; above 1000 "rad/s" the speed is in another unit
    on = np.isfinite(v) & engine_running(t, v) & (v < 1000.0)
    return float(dt[on].sum())


def temperature_check(test: Test, verdicts: _Verdicts) -> list[Finding]:
    """Ambient and coolant temperatures (degC, degF, K)."""
    out: list[Finding] = []

    def median(vals: np.ndarray) -> float:
        v = vals[np.isfinite(vals)]
        return float(np.median(v)) if v.size else float("nan")

    def top(vals: np.ndarray) -> float:
        v = vals[np.isfinite(vals)]
        return float(np.percentile(v, 99)) if v.size else float("nan")
    warm = _engine_running_s(test) >= WARM_UP_S
    for sig in test:
        if not sig.name.endswith("_test"):
            continue
        if sig.name.startswith("amb_temp"):
            out += _judge(test, sig, median, AMBIENT_TEMP_BAND, verdicts,
                          "the median ambient temperature [degC]", center=AMBIENT_TEMP_TYPICAL)
        elif sig.name.startswith("eng_temp_coolant"):
            band = COOLANT_WARM_BAND if warm else COOLANT_MAX_BAND
            out += _judge(test, sig, top, band, verdicts,
                          "the coolant's highest temperature [degC]"
                          + (f" after {WARM_UP_S / 60:.0f} min of a running engine"
                             if warm else ""), center=COOLANT_TYPICAL)
    return out


def pressure_check(test: Test, verdicts: _Verdicts) -> list[Finding]:
    """Ambient and intake manifold pressures (Pa, hPa, kPa, bar, psi)."""
    out: list[Finding] = []

    def median(vals: np.ndarray) -> float:
        v = vals[np.isfinite(vals)]
        return float(np.median(v)) if v.size else float("nan")
    for sig in test:
        if not sig.name.endswith("_test"):
            continue
        if sig.name.startswith("amb_pres"):
            out += _judge(test, sig, median, AMBIENT_PRES_BAND, verdicts,
                          "the median ambient pressure [Pa]")
        elif sig.name.startswith("eng_pres_intake"):
            out += _judge(test, sig, median, INTAKE_PRES_BAND, verdicts,
                          "the median intake manifold pressure [Pa]")
    return out


def phase_channel_check(test: Test) -> list[Finding]:
    """A phase channel must count phases: whole numbers, few values, few changes."""
    out: list[Finding] = []
    for sig in test:
        if not (sig.name.startswith("test_phase") and sig.name.endswith("_test")):
            continue
        v = np.asarray(sig.values, float)
        v = v[np.isfinite(v)]
        if v.size < 10:
            continue
        frac = float(np.mean(np.abs(v - np.round(v)) > 0.01))
        distinct = int(np.unique(np.round(v, 6)).size)
        changes = int(np.count_nonzero(np.diff(v)))
        if frac <= 0.01 and distinct <= PHASE_MAX_VALUES and changes <= PHASE_MAX_CHANGES:
            continue
        t0, t1 = _span(test)
        raw = sig.raw_name or sig.name
        out.append(Finding(
            sig.name, Kind.UNIT_SUSPECT, t0, t1, Severity.ERROR,
            f"{sig.name} (raw '{raw}') is no phase counter: {percent(frac, 0)} of its samples are not "
            f"whole numbers, {distinct} distinct values, {changes} changes: a wrong channel "
            "mapped as the phase channel",
            {"non_integer_fraction": frac, "distinct": distinct, "changes": changes},
            level=3, fix=f"map the file's phase (bag) column to {sig.name}, not '{raw}', or "
                         "remove the mapping to take the phases from the identified cycle"))
    return out


def header_conflict_check(test: Test, verdicts: _Verdicts, density: float | None
                          ) -> list[Finding]:
    """A template unit over the header's own that no physics check settled."""
    out: list[Finding] = []
    t0, t1 = _span(test)
    for sig in test:
        hdr = header_unit(sig)
        if hdr is None or sig.name in verdicts.ok or sig.name in verdicts.flagged:
            continue
        f = factor(sig, hdr, density)
        if not math.isfinite(f) or abs(f - 1.0) <= 0.02:
            continue                                 # the same unit spelt another way
        figure = sig.name.startswith(FIGURE_BASES)
        out.append(Finding(
            sig.name, Kind.UNIT_SUSPECT, t0, t1, Severity.ERROR if figure else Severity.WARNING,
            f"{sig.name}: the template declares {sig.raw_unit} but the file header of "
            f"{sig.raw_name} says {hdr} ({sig.raw_unit} -> {hdr} is {fmt_factor(f)}), and no "
            "physical check tells which is right",
            {"factor": f, "probable_unit": hdr, "declared_unit": sig.raw_unit},
            level=3, fix=f"declare {sig.raw_name} in {hdr}, as its header says, not "
                         f"{sig.raw_unit} ({fmt_factor(f)}), unless the header is known wrong"))
    return out


def run_crosschecks(test: Test, template: Any = None, vehicle: Any = None,
                    constants: dict | None = None) -> list[Finding]:
    """Every cross-check on an aligned test (see the module docstring).

    Parameters
    ----------
    test : Test
        The aligned test (SI units, raw units kept on each signal).
    template, vehicle : optional
        For the fuel (density [kg/m³], LHV [J/kg]).
    constants : dict, optional
        Template constants (``test_mass_kg`` [kg]).

    Returns
    -------
    list of Finding
        ``unit_suspect`` findings, each with its one-line ``fix``.
    """
    verdicts = _Verdicts()
    consts = dict(constants or {})
    density, _ = _fuel_density(template, test, vehicle)
    found = speed_cycle_check(test, verdicts, density)
    from vehval.qa.speed_scale import speed_scale_check

    scaled = speed_scale_check(test, verdicts.flagged, template)
    verdicts.flagged.update(f.signal for f in scaled)
    found += scaled
    found += force_mass_check(test, consts, verdicts)
    found += fuel_energy_check(test, template, vehicle, verdicts)
    found += engine_speed_check(test, verdicts)
    found += temperature_check(test, verdicts)
    found += pressure_check(test, verdicts)
    found += phase_channel_check(test)
    found += header_conflict_check(test, verdicts, density)
    from vehval.qa.obd_checks import obd_speed_unit_check

    done = {f.signal for f in found}
    found += [f for f in obd_speed_unit_check(test, verdicts.ok) if f.signal not in done]
    return found
