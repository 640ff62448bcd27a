"""The measured speed against the drive cycle's own distance: a speed scale.

A speed channel read a constant factor off (a ``scale:`` in the template, a roll diameter
or a speed calibration) keeps the cycle's shape, so every per-signal check passes, yet it
moves every distance and so every fuel economy by the factor. Two cases:

* the cycle was identified: the distance the measured speed covers over the cycle's runs
  is compared with the cycle's own distance;
* no cycle was identified as declared: the trace is searched for a cycle's shape at any
  factor (:func:`vehval.cycles_match.identify_scaled`); a cycle it then follows, with a
  distance off by more than the tolerance, names the factor.

A distance off by more than :data:`SPEED_SCALE_TOL` is an **error** on the speed (its
figures are withheld, :mod:`vehval.results.gate`) naming the factor and the fix.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.qa.findings import Finding, Kind, Severity
from vehval.test import Signal, Test

__all__ = ["SPEED_SCALE_TOL", "speed_scale_check"]

#: Largest relative difference [-] of the measured distance over the cycle's runs from the
#: cycle's own distance. The ANL D3 files (Cruze, Camry: 22 runs of UDDS, HWFET, US06, SC03,
#: NEDC, WLTC) lie within 0.7 %; a driver 2 % long over a whole run is outside the SAE J2951
#: RMSSE tolerance on every cycle faster than 40 mph on average, and 2 % of distance is more
#: than the 1.2 % expanded uncertainty of a fuel economy (Cruze HWFET 54.80 +- 0.66 mpg).
SPEED_SCALE_TOL = 0.02
#: Time-unit slips searched when no cycle is found at any speed factor: the record's time
#: read x factor (ms declared s: 0.001; min declared s: 60 ...) [-], and the durations a
#: scaled record must span to be searched [s] (a search never bins more than 6 h)
TIME_SLIPS = {0.001: "ms declared s", 1 / 60: "s declared min", 60.0: "min declared s",
              1 / 3600: "s declared h", 1000.0: "s declared ms"}
TIME_SLIP_SPAN_S = (120.0, 6 * 3600.0)


def _declared_scale(template: Any, sig: Signal) -> float | None:
    """The ``scale`` the template gives the speed's channel (None when none or 1)."""
    for spec in getattr(template, "files", None) or []:
        for raw, ch in (getattr(spec, "channels", None) or {}).items():
            if getattr(ch, "name", None) == sig.name and (sig.raw_name in (None, raw)):
                s = float(getattr(ch, "scale", 1.0) or 1.0)
                return s if s != 1.0 else None
    return None


def _finding(test: Test, sig: Signal, factor: float, cycle: str, identified: bool,
             template: Any) -> Finding:
    t0, t1 = test.span()
    raw = sig.raw_name or sig.name
    declared = _declared_scale(template, sig)
    what = (f"{sig.name} covers {factor:.4f} x the distance of {cycle} over its runs"
            if identified else
            f"{sig.name} follows no known drive cycle as declared, but follows {cycle} once "
            f"divided by {factor:.4f}: it covers {factor:.4f} x the cycle's distance over "
            "its runs")
    why = (f"the template declares scale {declared:g} for {raw}" if declared is not None
           else "a channel scale, a roll diameter or a speed calibration")
    probable = (declared or 1.0) / factor
    if declared is not None and abs(probable - 1.0) <= SPEED_SCALE_TOL:
        fix = (f"remove 'scale: {declared:g}' from {raw} ({sig.name}) in the template: the "
               "speed follows the cycle's distance without it")
    else:
        fix = (f"check the speed of {raw} ({sig.name}): set its 'scale' to about "
               f"{probable:.3g} in the template" +
               (f" (now {declared:g})" if declared is not None else "")
               + " or correct the dyno's speed calibration")
    return Finding(
        sig.name, Kind.UNIT_SUSPECT, float(t0), float(t1), Severity.ERROR,
        f"{what} (tolerance +-{SPEED_SCALE_TOL:.0%}): the speed reads {factor - 1:+.1%}, "
        f"a speed scale ({why}); every distance and fuel economy is off by that factor",
        {"factor": factor, "cycle": cycle, "tolerance": SPEED_SCALE_TOL,
         "declared_scale": declared, "probable_scale": probable, "identified": identified},
        level=3, fix=fix)


def speed_scale_check(test: Test, skip: set[str] | frozenset[str] = frozenset(),
                      template: Any = None) -> list[Finding]:
    """An error when the measured speed's distance over the cycle is off by a factor.

    Parameters
    ----------
    test : Test
        The aligned test (``meta.cycle_match`` from the import).
    skip : set of str
        Signals another check already flagged (a wrong unit): not judged again.
    template : Template, optional
        To name the channel's declared ``scale`` in the message and the fix.

    Returns
    -------
    list of Finding
        At most one ``unit_suspect`` error on the speed signal.
    """
    from vehval.cycles import list_cycles
    from vehval.cycles_match import identify_scaled, run_distance_ratios

    sig = test.best("veh_spd", ("test",))
    if sig is None or sig.name in skip or sig.values.size < 2:
        return []
    match = test.meta.cycle_match or {}
    if match.get("method") == "steady":
        return []
    if match.get("method") == "cycle" and match.get("name"):
        # the match's record times hold for every speed signal (found on another one: an
        # OBD speed when the dyno's followed no cycle), moved as its source was aligned
        src = str(match.get("source") or "")
        shift = (float((test.meta.offsets_s or {}).get(src, 0.0))
                 - float(match.get("source_offset_s") or 0.0))
        runs = run_distance_ratios(sig.time, sig.values, match, shift)
        ref = sum(r for _, r in runs)
        if ref <= 0:
            return []
        factor = sum(m for m, _ in runs) / ref
        name, identified = str(match["name"]), True
    else:
        base = (test.meta.cycle or "").split("_x")[0]
        cycles = [base] if base and base in list_cycles() else None
        found, factor, _ = identify_scaled(sig.time, sig.values, cycles=cycles)
        if found is None:
            return _time_slip(test, sig, cycles)
        name, identified = found, False
    if not (np.isfinite(factor) and abs(factor - 1.0) > SPEED_SCALE_TOL):
        return []
    return [_finding(test, sig, float(factor), name, identified, template)]


def _time_slip(test: Test, sig: Signal, cycles: list[str] | None) -> list[Finding]:
    """An error when the speed follows a cycle once the record's time is read in another
    unit (:data:`TIME_SLIPS`): every duration and distance is off by that factor."""
    from vehval.cycles_match import identify_cycle

    t = np.asarray(sig.time, float)
    ok = np.isfinite(t)
    if ok.sum() < 2:
        return []
    span = float(t[ok].max() - t[ok].min())
    for factor, slip in TIME_SLIPS.items():
        if not TIME_SLIP_SPAN_S[0] <= span * factor <= TIME_SLIP_SPAN_S[1]:
            continue
        found, _, det = identify_cycle(t * factor, sig.values, cycles=cycles)
        if found is None or det.get("method") != "cycle":
            continue
        t0, t1 = test.span()
        return [Finding(
            sig.name, Kind.UNIT_SUSPECT, float(t0), float(t1), Severity.ERROR,
            f"{sig.name} follows no drive cycle on the record's time base, but follows "
            f"{found} once the time is read x {factor:.4g} (a time column in {slip}?): every "
            f"duration and distance is off by {1 / factor:.4g} x",
            {"time_factor": factor, "cycle": found}, level=3,
            fix=f"declare the time column's unit in the template (x {factor:.4g}: {slip}) "
                "and import the test again")]
    return []
