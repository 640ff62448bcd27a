"""Unit plausibility: physics that catches a wrong unit in the template.

A unit error passes every per-signal check (the values are smooth, in range, consistent
with themselves) yet changes every result. Three checks look for the factor a unit error
leaves behind and name the likely error in the finding (kind ``unit_suspect``):

1. **cycle against the declared speed unit**: when the measured speed follows no known
   cycle as declared but does once multiplied by a unit factor (mph/km/h, km/h vs m/s);
2. **tractive force against the road-load model**: the slope of the measured force over
   ``m·a + A + B·v + C·v²`` (QA table 3) at a unit ratio (speed 1.609, force 4.448 lbf/N);
3. **fuel against power**: the tank-to-wheel efficiency (positive wheel energy over fuel
   energy) outside what a car can do, by a fuel unit factor (g/s vs kg/h 3.6, g vs kg 1000).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.constants import KMH_M_PER_S, LBF_N, MPH_M_PER_S
from vehval.fuels import resolve_fuel
from vehval.qa.findings import Finding, Kind, Severity
from vehval.test import Test

#: Speed unit mix-ups: factor to apply to the data as imported -> (declared, probably).
SPEED_FACTORS: dict[float, tuple[str, str]] = {
    MPH_M_PER_S / KMH_M_PER_S: ("km/h", "mph"),
    KMH_M_PER_S / MPH_M_PER_S: ("mph", "km/h"),
    KMH_M_PER_S: ("m/s", "km/h"),
    1.0 / KMH_M_PER_S: ("km/h", "m/s"),
}
#: Force unit mix-ups: slope measured / calculated -> (declared, probably).
FORCE_FACTORS: dict[float, tuple[str, str]] = {
    LBF_N: ("N", "lbf"),
    1.0 / LBF_N: ("lbf", "N"),
}
#: Fuel rate unit mix-ups: factor the imported rate is too small by -> (declared, probably).
FUEL_FACTORS: dict[float, tuple[str, str]] = {
    3.6: ("kg/h (or L/h)", "g/s (or cm³/s)"),
    1.0 / 3.6: ("g/s (or cm³/s)", "kg/h (or L/h)"),
    1000.0: ("kg/s", "g/s"),
    1e-3: ("g/s", "kg/s"),
    3600.0: ("per hour", "per second"),
    1.0 / 3600.0: ("per second", "per hour"),
}
#: Tank-to-wheel efficiency a car can show over a test (positive wheel energy / fuel energy):
#: at most the best engine's peak efficiency (about 45 %, a modern diesel); measured 13-22 %
#: on the Cruze diesel cycles, about 30 % on a virtual 2004 Prius.
EFFICIENCY_RANGE = (0.04, 0.45)
#: Relative tolerance of a slope or ratio on a unit factor.
FACTOR_TOL = 0.06


def _near(value: float, factors: dict[float, tuple[str, str]], tol: float = FACTOR_TOL
          ) -> tuple[float, tuple[str, str]] | None:
    for f, units in factors.items():
        if abs(value / f - 1.0) <= tol:
            return f, units
    return None


def _span(test: Test) -> tuple[float, float]:
    t0, t1 = test.span()
    return float(t0), float(t1)


def speed_unit_check(test: Test) -> tuple[list[Finding], float]:
    """Check 1; returns the findings and the speed factor to apply (1.0 when none)."""
    if test.meta.cycle:
        return [], 1.0
    sig = test.best("veh_spd", ("test",))
    if sig is None:
        return [], 1.0
    v = np.asarray(sig.values, float)
    if not np.any(np.nan_to_num(v) > 1.0):
        return [], 1.0
    from vehval.cycles_match import identify_cycle

    for f, (declared, probably) in SPEED_FACTORS.items():
        name, score, details = identify_cycle(sig.time, v * f)
        if name and details.get("method") == "cycle":
            t0, t1 = _span(test)
            return [Finding(
                sig.name, Kind.UNIT_SUSPECT, t0, t1, Severity.ERROR,
                f"{sig.name} follows no known cycle as imported but follows {name} when "
                f"multiplied by {f:.4g}: the data are probably in {probably}, declared "
                f"{declared}: fix the unit in the template",
                {"factor": f, "score": score}, level=3)], f
    return [], 1.0


def force_unit_check(table3: list[Any], speed_factor: float) -> list[Finding]:
    """Check 2 on the table-3 rows of the measured tractive force."""
    out: list[Finding] = []
    for row in table3:
        if not str(row.measured).startswith("veh_frc_in") or row.slope is None:
            continue
        if not (row.r2 is not None and row.r2 > 0.8 and np.isfinite(row.slope)):
            continue
        if speed_factor != 1.0:
            continue  # already explained by the speed unit
        hit = _near(row.slope, FORCE_FACTORS)
        speed = _near(row.slope, {f: u for f, u in SPEED_FACTORS.items() if f < 2})
        if hit is None and speed is None:
            continue
        if speed is not None:
            f, (declared, probably) = speed
            why = (f"the vehicle speed is probably in {probably}, declared {declared} "
                   "(the calculated force scales with the speed's unit)")
        elif hit is not None:  # one of the two, see above
            f, (declared, probably) = hit
            why = f"{row.measured} is probably in {probably}, declared {declared}"
        out.append(Finding(
            row.measured, Kind.UNIT_SUSPECT, 0.0, 0.0, Severity.ERROR,
            f"{row.measured} is {row.slope:.3g} times the road-load model "
            f"{row.calculated} (R² {row.r2:.2f}): a unit ratio of {f:.4g}: {why}: fix the "
            "unit in the template", {"slope": row.slope, "factor": f}, level=3,
            related=[row.calculated]))
    return out


def _integral(t: np.ndarray, y: np.ndarray) -> float:
    ok = np.isfinite(t) & np.isfinite(y)
    if ok.sum() < 2:
        return float("nan")
    return float(np.trapezoid(y[ok], t[ok]))


def fuel_unit_check(test: Test, template: Any = None, vehicle: Any = None,
                    speed_factor: float = 1.0) -> list[Finding]:
    """Check 3: tank-to-wheel efficiency over the test."""
    fuel = test.best("fuel_rate", ("test",))
    spd = test.best("veh_spd", ("test",))
    frc = test.best("veh_frc_in", ("test",))
    if fuel is None or spd is None or frc is None:
        return []
    t = np.asarray(frc.time, float)
    p = np.asarray(frc.values, float) * spd.at(t) * speed_factor
    e_wheel = _integral(t, np.maximum(p, 0.0))
    fuel_decl = resolve_fuel(template=template, test=test, vehicle=vehicle)
    lhv = fuel_decl.lhv_j_per_kg if fuel_decl is not None else None
    if not lhv:  # no fuel declared: the efficiency is unknown
        return []
    e_fuel = _integral(np.asarray(fuel.time, float), np.maximum(np.asarray(fuel.values, float), 0.0)) * lhv
    if not (np.isfinite(e_wheel) and np.isfinite(e_fuel)) or e_fuel <= 0 or e_wheel <= 1e4:
        return []
    eff = e_wheel / e_fuel
    lo, hi = EFFICIENCY_RANGE
    if lo <= eff <= hi:
        return []
    for f, (declared, probably) in FUEL_FACTORS.items():
        if lo <= eff / f <= hi and (f > 1) == (eff > hi):
            t0, t1 = _span(test)
            return [Finding(
                fuel.name, Kind.UNIT_SUSPECT, t0, t1, Severity.ERROR,
                f"{fuel.name} gives a tank-to-wheel efficiency of {eff:.0%} ({e_wheel / 1e6:.3g} MJ "
                f"at the wheels from {e_fuel / 1e6:.3g} MJ of fuel), outside "
                f"{lo:.0%}..{hi:.0%}; {eff / f:.0%} with a factor {f:.4g}: the fuel rate is "
                f"probably {probably}, declared {declared}: fix the unit in the template",
                {"efficiency": eff, "factor": f}, level=3, related=[frc.name, spd.name])]
    return []


def run_plausibility(test: Test, table3: list[Any], template: Any = None,
                     vehicle: Any = None) -> list[Finding]:
    """Every unit plausibility check on an aligned test (see the module docstring)."""
    found, speed_factor = speed_unit_check(test)
    if not found:
        found += force_unit_check(table3, 1.0)
        for f in found:
            if "vehicle speed is probably" in f.message:
                speed_factor = f.numbers["factor"]
    found += fuel_unit_check(test, template, vehicle, speed_factor)
    return found
