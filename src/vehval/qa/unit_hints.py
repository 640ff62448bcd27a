"""Unit hints: which unit the data are probably in, given a physical statistic.

A unit mistake in a template multiplies a signal by a fixed factor (or shifts it, for
temperatures). When a physical statistic of the signal (a whole-test efficiency, an idle
speed, an ambient temperature...) is impossible as declared, the data are read again in
each unit of the same quantity; the units that make the statistic possible are the probable
ones. The hint names the declared unit, the probable one and the factor from one to the
other in SI (``mg/s -> g/s`` is x1000).

The unit written in the file's own header (when the template overrides it) is preferred
among the candidates: the file states it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Callable

import numpy as np

from vehval.test import Signal
from vehval.units import conversion

#: Units tried for each SI unit of the registry (raw spellings the unit parser accepts).
CANDIDATES: dict[str, tuple[str, ...]] = {
    "kg/s": ("mg/s", "g/s", "kg/s", "g/min", "g/h", "kg/h", "lb/h",
             "ccps", "mL/min", "L/s", "L/h", "gal/h"),
    "m/s": ("m/s", "km/h", "mph"),
    "rad/s": ("rad/s", "rpm"),
    "degC": ("degC", "degF", "K"),
    "Pa": ("Pa", "hPa", "kPa", "bar", "psi"),
    "N": ("N", "kN", "lbf"),
}
#: Volume-rate spellings (a fuel declared in one of these is converted with the density).
VOLUME_UNITS = frozenset({"ccps", "cm^3/s", "cm³/s", "ml/s", "ml/min", "l/s", "l/h", "gal/h",
                          "cc/s", "l/min"})

_HEADER = re.compile(r"template unit '(?P<tpl>.+?)' used instead of header unit '(?P<hdr>.+?)'")


def header_unit(sig: Signal) -> str | None:
    """The unit in the file's header when the template declared another one, else None."""
    for note in sig.notes:
        m = _HEADER.search(note)
        if m:
            return m.group("hdr")
    return None


def is_volume(unit: str | None) -> bool:
    """True for a volume-rate spelling (``ccps``, ``L/h``...)."""
    return unit is not None and unit.strip().lower().replace(" ", "") in VOLUME_UNITS


def _conv(unit: str | None, si_unit: str, density: float | None) -> tuple[float, float] | None:
    try:
        return conversion(unit, si_unit, fuel_density_kg_per_m3=density)
    except Exception:  # noqa: BLE001 - any unit the parser refuses is simply not a candidate
        return None


def reinterpret(sig: Signal, unit: str, density: float | None = None) -> np.ndarray | None:
    """The signal's SI values had its raw numbers been declared in ``unit``; None when
    either unit does not convert to the signal's SI unit."""
    declared = _conv(sig.raw_unit, sig.unit, density)
    other = _conv(unit, sig.unit, density)
    if declared is None or other is None or declared[0] == 0:
        return None
    raw = (np.asarray(sig.values, float) - declared[1]) / declared[0]
    return raw * other[0] + other[1]


def factor(sig: Signal, unit: str, density: float | None = None) -> float:
    """Ratio of the SI scales, ``unit`` over the declared unit (x1000 for mg/s -> g/s)."""
    declared = _conv(sig.raw_unit, sig.unit, density)
    other = _conv(unit, sig.unit, density)
    if declared is None or other is None or declared[0] == 0:
        return float("nan")
    return other[0] / declared[0]


@dataclass
class UnitHint:
    """One unit that makes the statistic possible."""

    unit: str
    factor: float          # SI scale of ``unit`` over the declared one
    value: float           # the statistic with the data read in ``unit``


def _same(a: str | None, b: str | None) -> bool:
    return (a or "").strip().lower().replace(" ", "") == (b or "").strip().lower().replace(" ", "")


def probable_units(sig: Signal, stat: Callable[[np.ndarray], float], band: tuple[float, float],
                   *, density: float | None = None, center: float | None = None
                   ) -> list[UnitHint]:
    """Candidate units of ``sig`` whose reading puts ``stat`` inside ``band``, best first.

    Best first: the file header's unit, then units of the declared kind (mass or volume for
    a fuel rate), then the statistic closest to ``center`` (log scale; the band's geometric
    middle by default, arithmetic for a band that crosses zero).
    """
    lo, hi = band
    hdr = header_unit(sig)
    mid = center if center is not None else (
        math.sqrt(lo * hi) if lo > 0 else 0.5 * (lo + hi))
    hits: list[tuple[tuple[int, int, float], UnitHint]] = []
    for unit in CANDIDATES.get(sig.unit, ()):
        if _same(unit, sig.raw_unit):
            continue
        vals = reinterpret(sig, unit, density)
        if vals is None:
            continue
        s = stat(vals)
        if not (math.isfinite(s) and lo <= s <= hi):
            continue
        f = factor(sig, unit, density)
        cur = np.asarray(sig.values, float)
        if np.allclose(vals, cur, rtol=0.02, equal_nan=True) and not _same(unit, hdr):
            continue                        # the same unit under another name
        dist = abs(math.log(s / mid)) if lo > 0 and s > 0 else abs(s - mid)
        rank = (0 if _same(unit, hdr) else 1,
                0 if is_volume(unit) == is_volume(sig.raw_unit) else 1, dist)
        hits.append((rank, UnitHint(unit, f, s)))
    hits.sort(key=lambda h: h[0])
    if hdr is not None and hits and not _same(hits[0][1].unit, hdr):
        # the header's spelling may not be a candidate: put it first when it fits too
        vals = reinterpret(sig, hdr, density)
        if vals is not None and lo <= stat(vals) <= hi:
            hits.insert(0, ((0, 0, 0.0), UnitHint(hdr, factor(sig, hdr, density), stat(vals))))
    return [h for _, h in hits]


def fmt_factor(f: float) -> str:
    """``x1000``, ``x3.6``, ``x0.2778``."""
    return f"x{f:.4g}"


def change_text(sig: Signal, hint: UnitHint) -> str:
    """The factor, or the offset for a temperature (``x1000``, ``-273.15``)."""
    declared = _conv(sig.raw_unit, sig.unit, None)
    other = _conv(hint.unit, sig.unit, None)
    if declared is not None and other is not None and (declared[1] or other[1]):
        vals = reinterpret(sig, hint.unit)        # affine (temperatures): the shift
        if vals is not None:
            d = float(np.nanmedian(vals - np.asarray(sig.values, float)))
            return f"{d:+.5g} {sig.unit} at the median"
    return fmt_factor(hint.factor)


def fix_text(sig: Signal, hint: UnitHint) -> str:
    """One-line fix: "declare Fuel_Flow in g/s, not mg/s (x1000)"."""
    raw = sig.raw_name or sig.name
    return (f"declare {raw} ({sig.name}) in {hint.unit}, not {sig.raw_unit} "
            f"({change_text(sig, hint)})")


def hint_sentence(sig: Signal, hints: list[UnitHint]) -> str:
    """``declared mg/s; the data say g/s (x1000)`` plus the other fitting units."""
    best = hints[0]
    text = (f"declared {sig.raw_unit}; the data say {best.unit} "
            f"({sig.raw_unit} -> {best.unit} is {change_text(sig, best)})")
    others = [h.unit for h in hints[1:3]]
    if others:
        text += f" (also possible: {', '.join(others)})"
    hdr = header_unit(sig)
    if hdr is not None:
        text += f"; the file header says {hdr}"
    return text
