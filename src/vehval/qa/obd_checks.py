"""Unit checks that follow from the OBD-II standard itself, for logs with no drive cycle,
no force and no test mass to check a speed against (on-road logs).

SAE J1979 (ISO 15031-5) defines mode 01 PID 0x0D, vehicle speed, as one byte in km/h with a
resolution of 1 km/h (0..255 km/h). A logger that passes the value through writes whole
km/h; one that converts to mph or m/s writes fractions. So an OBD speed channel whose raw
numbers are all whole numbers, declared in a unit other than km/h, is almost surely the
PID's km/h: read in the declared unit every distance and speed of the log would be off by
the ratio of the two units (x1.609 for mph), with nothing else in the log to show it.
"""

from __future__ import annotations

import numpy as np

from vehval.qa.findings import Finding, Kind, Severity
from vehval.qa.unit_hints import UnitHint, factor, fix_text, fmt_factor, reinterpret
from vehval.test import Signal, Test

#: The unit of SAE J1979 mode 01 PID 0x0D (vehicle speed).
PID_SPEED_UNIT = "km/h"
#: Least number of moving samples and of distinct moving values before the raw numbers'
#: being whole says anything (a short or constant log proves nothing).
MIN_MOVING_SAMPLES, MIN_DISTINCT = 30, 8
#: Tolerance on "whole number" after the unit round trip (floating point only).
WHOLE_TOL = 1e-6


def _raw_numbers(sig: Signal) -> np.ndarray | None:
    """The channel's numbers as they were in the file (declared unit)."""
    from vehval.units import conversion

    try:
        scale, off = conversion(sig.raw_unit or "", sig.unit)
    except Exception:  # noqa: BLE001 - a unit that does not convert back is skipped
        return None
    if not scale:
        return None
    return (np.asarray(sig.values, float) - off) / scale


def obd_speed_unit_check(test: Test, vouched: set[str]) -> list[Finding]:
    """An OBD vehicle speed declared in mph or m/s whose raw numbers are whole km/h.

    Parameters
    ----------
    test : Test
        The aligned test (SI units, raw units kept on each signal).
    vouched : set of str
        Signals another check already found right as declared (e.g. the speed follows a
        drive cycle): they are not questioned here.

    Returns
    -------
    list of Finding
        At most one ``unit_suspect`` error per OBD speed channel, with its fix.
    """
    out: list[Finding] = []
    for sig in test.by_base("veh_spd"):
        if sig.source != "obd" or not sig.raw_unit or sig.name in vouched:
            continue
        if sig.raw_unit.replace(" ", "").lower() in ("km/h", "kph", "kmh", "km/hr"):
            continue
        raw = _raw_numbers(sig)
        if raw is None:
            continue
        raw = raw[np.isfinite(raw)]
        moving = raw[raw > 0.5]
        if moving.size < MIN_MOVING_SAMPLES or np.unique(moving).size < MIN_DISTINCT:
            continue
        if not np.all(np.abs(moving - np.round(moving)) <= WHOLE_TOL * np.maximum(1.0, moving)):
            continue
        f = factor(sig, PID_SPEED_UNIT)
        vals = reinterpret(sig, PID_SPEED_UNIT)
        if vals is None or not np.isfinite(f):
            continue
        hint = UnitHint(PID_SPEED_UNIT, f, float(np.nanpercentile(vals, 99.9)))
        t0, t1 = test.span()
        out.append(Finding(
            sig.name, Kind.UNIT_SUSPECT, float(t0), float(t1), Severity.ERROR,
            f"{sig.name} (raw '{sig.raw_name}') is an OBD speed whose {moving.size} moving "
            f"samples are all whole numbers: SAE J1979 PID 0x0D gives whole km/h, a "
            f"conversion to {sig.raw_unit} would give fractions; declared {sig.raw_unit}, "
            f"probably km/h ({sig.raw_unit} -> km/h is {fmt_factor(f)})",
            {"factor": f, "probable_unit": PID_SPEED_UNIT, "declared_unit": sig.raw_unit,
             "moving_samples": int(moving.size), "distinct_values": int(np.unique(moving).size)},
            level=3, fix=fix_text(sig, hint)))
    return out
