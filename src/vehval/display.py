"""Display units: the one table that turns SI values into what an engineer reads.

Data files and JSON stay SI. Everything a person reads (screen, report, Excel, batch index)
converts here, at display time only, in one of two unit systems:

* ``us`` (the default: the regulatory figures vehval states are EPA's): mph, mi, mpg, lbf, lb;
* ``metric``: km/h, km, L/100 km, N, kg.

Both systems share the engineering units a test cell reads whatever its country: rpm, g/s,
kW, kJ or MJ, degC, kPa, N·m, %. The system is chosen with the CLI's global
``--units us|metric`` or the ``VEHVAL_UNITS`` environment variable (the CLI sets it).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Iterable, overload

import numpy as np

from vehval.constants import (
    KMH_M_PER_S,
    KWH_J,
    LB_KG,
    LBF_N,
    MILE_M,
    MPH_M_PER_S,
    RPM_RAD_PER_S,
    UNITS_ENV_VAR,
)
from vehval.fuels.quantities import VOLUME_DISPLAY

#: The unit systems a person can choose.
SYSTEMS: tuple[str, ...] = ("us", "metric")
#: The system used when none is chosen.
DEFAULT_SYSTEM = "us"
#: Environment variable holding the chosen system (set by the CLI's ``--units``).
ENV_VAR = UNITS_ENV_VAR


@dataclass(frozen=True)
class DisplayUnit:
    """A display unit: ``shown = value_si * factor + offset``.

    Attributes
    ----------
    label : str
        The unit as printed (``"mph"``, ``"degC"``...).
    factor : float
        Multiplier SI -> display [display unit per SI unit].
    offset : float
        Added after the factor (temperatures in kelvin only) [display unit].
    """

    label: str
    factor: float = 1.0
    offset: float = 0.0

    def convert(self, value_si: float | np.ndarray) -> float | np.ndarray:
        """SI value(s) -> display value(s)."""
        return value_si * self.factor + self.offset


def _same(label: str, factor: float = 1.0, offset: float = 0.0) -> dict[str, DisplayUnit]:
    unit = DisplayUnit(label, factor, offset)
    return {"us": unit, "metric": unit}


#: SI unit (as the nomenclature writes it) -> system -> display unit.
TABLE: dict[str, dict[str, DisplayUnit]] = {
    "m/s": {"us": DisplayUnit("mph", 1.0 / MPH_M_PER_S),
            "metric": DisplayUnit("km/h", 1.0 / KMH_M_PER_S)},
    "m/s**2": {"us": DisplayUnit("mph/s", 1.0 / MPH_M_PER_S),
               "metric": DisplayUnit("m/s²")},
    "m": {"us": DisplayUnit("mi", 1.0 / MILE_M), "metric": DisplayUnit("km", 1.0e-3)},
    "m**3": {name: DisplayUnit(*VOLUME_DISPLAY[name]) for name in ("us", "metric")},
    "kg": {"us": DisplayUnit("lb", 1.0 / LB_KG), "metric": DisplayUnit("kg")},
    "N": {"us": DisplayUnit("lbf", 1.0 / LBF_N), "metric": DisplayUnit("N")},
    "rad/s": _same("rpm", 1.0 / RPM_RAD_PER_S),
    "kg/s": _same("g/s", 1.0e3),
    "W": _same("kW", 1.0e-3),
    "Pa": _same("kPa", 1.0e-3),
    "K": _same("degC", 1.0, -273.15),
    "degC": _same("degC"),
    "N*m": _same("N·m"),
    "s": _same("s"),
    "V": _same("V"),
    "A": _same("A"),
    "ohm": _same("Ω"),
    "W/m**2": _same("W/m²"),
}
#: Energies: kJ below this magnitude [J], MJ from it.
_MJ_FROM_J = 1.0e6
_ALIASES = {"m/s^2": "m/s**2", "m^3": "m**3", "N m": "N*m", "N.m": "N*m", "Nm": "N*m",
            "kelvin": "K", "celsius": "degC", "": "dimensionless", "1": "dimensionless"}
_PERCENT = DisplayUnit("%", 100.0)
_PLAIN = DisplayUnit("")


def system(chosen: str | None = None) -> str:
    """The unit system in force: ``chosen``, else ``$VEHVAL_UNITS``, else the default.

    Raises
    ------
    ValueError
        When the system is not one of :data:`SYSTEMS` (the message lists them).
    """
    name = (chosen or os.environ.get(ENV_VAR) or DEFAULT_SYSTEM).strip().lower()
    if name not in SYSTEMS:
        raise ValueError(f"unknown unit system {name!r}: use one of {', '.join(SYSTEMS)}")
    return name


def _is_fraction(signal: str | None) -> bool:
    """True for a dimensionless signal whose plausible range lies within [0, 1] (SOC,
    efficiency, pedal position, relative humidity): shown in percent."""
    if not signal:
        return False
    from vehval.errors import SignalError
    from vehval.nomenclature import registry

    reg = registry()
    try:
        spec = reg.spec_of(signal) if signal.rsplit("_", 1)[-1] in ("test", "calc", "simu") \
            else reg[signal]
    except (SignalError, KeyError):
        return False                     # an unknown name is simply not a fraction
    lo, hi = spec.range
    return spec.unit == "dimensionless" and 0.0 <= lo and 0.0 < hi <= 1.0


def unit_for(si_unit: str, *, system_name: str | None = None, signal: str | None = None,
             magnitude: float | None = None) -> DisplayUnit:
    """Display unit of an SI unit.

    Parameters
    ----------
    si_unit : str
        The SI unit as the nomenclature writes it (``"m/s"``, ``"rad/s"``, ``"J"``...).
    system_name : str, optional
        ``us`` or ``metric``; default :func:`system`.
    signal : str, optional
        Standard signal name: a dimensionless fraction (SOC, efficiency) is shown in %.
    magnitude : float, optional
        Typical absolute value [SI] (an axis maximum, the value itself): picks kJ or MJ.

    Returns
    -------
    DisplayUnit
        Unchanged (factor 1) for a unit the table does not know.
    """
    key = _ALIASES.get(si_unit.strip(), si_unit.strip())
    if key == "J":
        big = magnitude is not None and math.isfinite(magnitude) and abs(magnitude) >= _MJ_FROM_J
        return DisplayUnit("MJ", 1.0e-6) if big else DisplayUnit("kJ", 1.0e-3)
    if key == "dimensionless":
        return _PERCENT if _is_fraction(signal) else _PLAIN
    row = TABLE.get(key)
    if row is None:
        return DisplayUnit(si_unit)
    return row[system(system_name)]


def to_display(values_si: np.ndarray, si_unit: str, *, system_name: str | None = None,
               signal: str | None = None) -> tuple[np.ndarray, str]:
    """An SI array in its display unit (kJ/MJ chosen from the array's largest magnitude).

    Returns
    -------
    (ndarray, str)
        The converted values and the unit label.
    """
    arr = np.asarray(values_si, dtype=float)
    finite = arr[np.isfinite(arr)]
    magnitude = float(np.max(np.abs(finite))) if finite.size else None
    unit = unit_for(si_unit, system_name=system_name, signal=signal, magnitude=magnitude)
    return np.asarray(unit.convert(arr), dtype=float), unit.label


#: Fixed display unit label -> (the SI unit it shows, factor from SI): what a page writes in
#: one named unit whatever the unit system (a plot axis in kW, an energy table in MJ).
FIXED: dict[str, tuple[str, float]] = {
    "g/s": ("kg/s", 1.0e3), "g": ("kg", 1.0e3), "kW": ("W", 1.0e-3), "kJ": ("J", 1.0e-3),
    "MJ": ("J", 1.0e-6), "Wh": ("J", 1.0 / 3600.0), "kWh": ("J", 1.0 / KWH_J),
    "km": ("m", 1.0e-3), "mi": ("m", 1.0 / MILE_M), "lb": ("kg", 1.0 / LB_KG), "%": ("dimensionless", 100.0),
    "rpm": ("rad/s", 1.0 / RPM_RAD_PER_S), "mph": ("m/s", 1.0 / MPH_M_PER_S),
    "km/h": ("m/s", 1.0 / KMH_M_PER_S), "kW/L": ("W/L", 1.0e-3),
}


@overload
def as_unit(value_si: float, label: str) -> float: ...
@overload
def as_unit(value_si: np.ndarray, label: str) -> np.ndarray: ...
def as_unit(value_si: float | np.ndarray, label: str) -> float | np.ndarray:
    """An SI value (or array) in the fixed display unit ``label`` (:data:`FIXED`):
    ``as_unit(0.0021, "g/s")`` -> 2.1, ``as_unit(0.25, "%")`` -> 25.0 (a fraction [-] as a
    percentage), ``as_unit(3.6e6, "kWh")`` -> 1.0; ValueError naming the known labels."""
    try:
        factor = FIXED[label][1]
    except KeyError:
        raise ValueError(f"no fixed display unit {label!r} (known: {', '.join(FIXED)})") \
            from None
    return value_si * factor


def number(value: float, digits: int = 4) -> str:
    """A number to ``digits`` significant digits without trailing zeros, in plain notation
    between 1e-3 and 1e7 (``-0.001``, ``30.2``, ``12 345``), scientific outside; ``n/a`` when
    not finite."""
    if value is None or not math.isfinite(value):
        return "n/a"
    if value == 0:
        return "0"
    exponent = math.floor(math.log10(abs(value)))
    if exponent < -3 or exponent >= 7:
        mantissa, _, exp = f"{value:.{max(digits - 1, 0)}e}".partition("e")
        if "." in mantissa:
            mantissa = mantissa.rstrip("0").rstrip(".")
        return f"{mantissa}e{exp}"
    decimals = max(digits - 1 - exponent, 0)
    text = f"{value:.{decimals}f}"
    if "." in text:                      # significant digits only: 0.032, not 0.03200
        text = text.rstrip("0").rstrip(".")
    if exponent >= 4:                    # thin-space thousands: 12 345
        whole, _, frac = text.partition(".")
        sign = "-" if whole.startswith("-") else ""
        digits_ = whole.lstrip("-")
        groups = [digits_[max(i - 3, 0):i] for i in range(len(digits_), 0, -3)][::-1]
        text = sign + "\u2009".join(groups) + (f".{frac}" if frac else "")
    return text


#: The smallest share :func:`percent` writes out [%]; below it: ``< 0.0001 %``.
PERCENT_FLOOR = 1e-4


def percent(fraction: float | None, decimals: int = 1) -> str:
    """A fraction [-] as a percentage with its sign: ``0.1234`` -> ``"12.3 %"``.

    ``decimals`` decimals, more where they would hide a difference: two significant digits
    for a non-zero share below 1 % (``0.014 %``, never ``0.0 %``) and for the distance to
    100 % just short of it (``99.986 %``, never ``100.0 %``), to at most four decimals
    (``< 0.0001 %``, ``> 99.9999 %`` beyond); ``n/a`` when not finite.

    Parameters
    ----------
    fraction : float or None
        The share [-] (1 is 100 %).
    decimals : int
        Decimals of a share from 1 to 99 % [-].

    Returns
    -------
    str
        The percentage followed by `` %``.
    """
    if fraction is None or not math.isfinite(fraction):
        return "n/a"
    p = 100.0 * float(fraction)
    a, sign = abs(p), "-" if p < 0 else ""
    if 0.0 < a < PERCENT_FLOOR:
        return f"< {PERCENT_FLOOR:g} %" if p > 0 else f"> -{PERCENT_FLOOR:g} %"
    if 0.0 < 100.0 - a < PERCENT_FLOOR:
        return f"> {100 - PERCENT_FLOOR:g} %" if p > 0 else f"< -{100 - PERCENT_FLOOR:g} %"
    digits = max(decimals, 0)
    for gap in (a, 100.0 - a):           # the share, and what it lacks to the whole
        if 0.0 < gap < 1.0:
            digits = max(digits, min(1 - math.floor(math.log10(gap)), 4))
    return f"{sign}{a:.{digits}f} %"


def format_value(value_si: float, si_unit: str, *, system_name: str | None = None,
                 signal: str | None = None, digits: int = 4) -> str:
    """One SI value as a person reads it: ``-1e-06`` kg/s -> ``"-0.001 g/s"``.

    Examples
    --------
    >>> format_value(25.0, "m/s", system_name="metric")
    '90 km/h'
    >>> format_value(3.02e7, "J")
    '30.2 MJ'
    """
    if value_si is None or not math.isfinite(float(value_si)):
        return "n/a"
    unit = unit_for(si_unit, system_name=system_name, signal=signal, magnitude=float(value_si))
    shown = number(float(unit.convert(float(value_si))), digits)
    return f"{shown} {unit.label}".rstrip()


def format_delta(value_si: float, si_unit: str, *, signal: str | None = None, digits: int = 4,
                 signed: bool = False, system_name: str | None = None) -> str:
    """A difference, step or threshold of an SI quantity in its display unit (the factor
    only: a temperature difference has no offset). ``signed`` prints ``+`` for positive."""
    if value_si is None or not math.isfinite(float(value_si)):
        return "n/a"
    unit = unit_for(si_unit, system_name=system_name, signal=signal, magnitude=float(value_si))
    shown = number(float(value_si) * unit.factor, digits)
    if signed and not shown.startswith("-"):
        shown = "+" + shown
    return f"{shown} {unit.label}".rstrip()


def format_range(lo_si: float, hi_si: float, si_unit: str, *, signal: str | None = None,
                 digits: int = 4, system_name: str | None = None) -> str:
    """``[lo, hi] unit`` of an SI interval in the display unit (both ends one unit)."""
    mag = max(abs(lo_si), abs(hi_si)) if math.isfinite(lo_si) and math.isfinite(hi_si) else None
    unit = unit_for(si_unit, system_name=system_name, signal=signal, magnitude=mag)
    lo, hi = (number(float(unit.convert(x)), digits) for x in (lo_si, hi_si))
    return f"[{lo}, {hi}] {unit.label}".rstrip()


#: Suffixes of result keys (``distance_m``, ``fuel_mass_kg``...) -> SI unit.
KEY_SUFFIX_UNITS: dict[str, str] = {
    "_mps": "m/s", "_m": "m", "_kg": "kg", "_j": "J", "_w": "W", "_s": "s", "_m3": "m**3",
    "_pa": "Pa", "_n": "N", "_rad_per_s": "rad/s", "_kg_per_s": "kg/s", "_k": "K",
}


#: Suffixes of compound keys (``fuel_lhv_j_per_kg``, ``road_load_b_n_per_mps``...) -> system
#: -> display unit. The last token of a ``_per_`` key (``_kg`` of ``_j_per_kg``) is a
#: denominator, not the value's unit: such a key with no entry here shows its number only.
KEY_SUFFIX_COMPOUND: dict[str, dict[str, DisplayUnit]] = {
    "_j_per_kg": _same("MJ/kg", 1.0e-6),
    "_kg_per_m3": _same("kg/m³"),
    "_n_per_mps": {"us": DisplayUnit("lbf/mph", MPH_M_PER_S / LBF_N),
                   "metric": DisplayUnit("N/(m/s)")},
    "_n_per_mps2": {"us": DisplayUnit("lbf/mph²", MPH_M_PER_S ** 2 / LBF_N),
                    "metric": DisplayUnit("N/(m/s)²")},
}


#: A ``_m`` key below this magnitude is a dimension (wheel radius), shown in m [m].
_LENGTH_M_BELOW = 10.0
#: Result keys that are fractions (shown in %) and keys already in a display unit.
KEY_FRACTIONS: frozenset[str] = frozenset({"soc_change"})
_KEY_DISPLAY_SUFFIXES = {"_mpg": "mpg", "_l_per_100km": "L/100 km", "_g_per_km": "g/km",
                         "_mpge": "MPGe", "_kwh_per_100km": "kWh/100 km",
                         "_kwh_per_100mi": "kWh/100 mi"}


def keyed_unit(key: str, *, system_name: str | None = None,
               magnitude: float | None = None) -> DisplayUnit | None:
    """Display unit of a value whose key names its unit by suffix (``distance_m``,
    ``fuel_lhv_j_per_kg``, ``headline_mpg``, ``soc_change`` in %), ``None`` when the key
    names none.

    Parameters
    ----------
    magnitude : float, optional
        Typical absolute value [SI]: picks kJ or MJ.
    """
    if key in KEY_FRACTIONS:
        return _PERCENT
    for suffix, label in _KEY_DISPLAY_SUFFIXES.items():
        if key.endswith(suffix):
            return DisplayUnit(label)
    for suffix, row in sorted(KEY_SUFFIX_COMPOUND.items(), key=lambda kv: -len(kv[0])):
        if key.endswith(suffix):
            return row[system(system_name)]
    for suffix in sorted(KEY_SUFFIX_UNITS, key=len, reverse=True):
        if key.endswith(suffix) and key[: -len(suffix)].endswith("_per"):
            return None                  # a denominator (``_j_per_kg``): not the value's unit
        if key.endswith(suffix):
            if suffix == "_m" and magnitude is not None and abs(magnitude) < _LENGTH_M_BELOW:
                return DisplayUnit("m")      # a wheel radius, not a distance: 0.305 m
            return unit_for(KEY_SUFFIX_UNITS[suffix], system_name=system_name,
                            magnitude=magnitude)
    return None


def keyed_metric(key: str, *, system_name: str | None = None,
                 magnitude: float | None = None) -> tuple[str, DisplayUnit | None]:
    """A result key as a table row names it: ``fuel_mass_kg`` -> ``("fuel_mass", lb)``
    (the SI suffix dropped when the value is shown converted), ``headline_mpg`` ->
    ``("headline_mpg", mpg)``; the unit is ``None`` when the key names none."""
    unit = keyed_unit(key, system_name=system_name, magnitude=magnitude)
    if unit is not None:
        for suffix in sorted(KEY_SUFFIX_UNITS, key=len, reverse=True):
            if key.endswith(suffix) and not key[: -len(suffix)].endswith("_per"):
                return key[: -len(suffix)], unit
    return key, unit


def format_keyed(key: str, value_si: float, *, system_name: str | None = None,
                 digits: int = 4) -> str:
    """A value whose key names its SI unit by suffix (``distance_m``, ``fuel_energy_j``,
    ``fuel_lhv_j_per_kg``...).

    Keys already in a display unit (``fuel_economy_mpg``, ``co2_g_per_km``,
    ``fuel_consumption_l_per_100km``), unknown suffixes and ``_per_`` keys of no known
    compound unit keep their value unchanged.

    Examples
    --------
    >>> format_keyed("fuel_lhv_j_per_kg", 42.8e6)
    '42.8 MJ/kg'
    >>> format_keyed("road_load_b_n_per_mps", 12.334, system_name="us")
    '1.24 lbf/mph'
    """
    if value_si is None or not math.isfinite(float(value_si)):
        return "n/a"
    unit = keyed_unit(key, system_name=system_name, magnitude=float(value_si))
    if unit is None or unit.label in _KEY_DISPLAY_SUFFIXES.values() or unit is _PERCENT:
        return number(float(value_si), digits)
    return f"{number(float(unit.convert(float(value_si))), digits)} {unit.label}".rstrip()


def fuel_figures(mpg: float | None, l_per_100km: float | None, *,
                 system_name: str | None = None) -> list[tuple[str, float | None]]:
    """The fuel figures in reading order: ``us`` mpg first then L/100 km, ``metric`` the
    reverse. Both are always given: a laboratory quotes both."""
    pair = [("mpg", mpg), ("L/100 km", l_per_100km)]
    return pair if system(system_name) == "us" else pair[::-1]


def fuel_text(mpg: float | None, l_per_100km: float | None, *,
              system_name: str | None = None) -> str:
    """``"54.8 mpg (4.29 L/100 km)"`` (us) or ``"4.29 L/100 km (54.8 mpg)"`` (metric)."""
    def one(name: str, value: float | None) -> str:
        if value is None or not math.isfinite(value):
            return f"n/a {name}"
        return f"{value:.1f} {name}" if name == "mpg" else f"{value:.2f} {name}"

    (a, va), (b, vb) = fuel_figures(mpg, l_per_100km, system_name=system_name)
    return f"{one(a, va)} ({one(b, vb)})"


def labels(units: Iterable[str], *, system_name: str | None = None) -> list[str]:
    """Display labels of several SI units (table headers)."""
    return [unit_for(u, system_name=system_name).label for u in units]
