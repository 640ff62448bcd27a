"""The package's single pint registry and SI conversion helpers.

Units are converted once, at import and at export; everything inside is SI floats.
"""

from __future__ import annotations

import math
import re
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np

from vehval.errors import UnitError

if TYPE_CHECKING:
    import pint


@lru_cache(maxsize=1)
def registry() -> pint.UnitRegistry:
    """The package's pint registry, built on first use (importing pint and building the
    registry take about 0.5 s, which a conversion between identical units does not need)."""
    import pint

    reg: pint.UnitRegistry = pint.UnitRegistry(autoconvert_offset_to_baseunit=True)
    reg.define("cc_per_second = cubic_centimeter / second = ccps")
    reg.define("percent_fraction = 0.01 = pct")
    return reg


def _pint_error() -> type[Exception]:
    import pint

    return pint.PintError


def __getattr__(name: str) -> Any:
    # ``units.ureg`` (and ``from vehval.units import ureg``): the registry, built on first use
    if name == "ureg":
        return registry()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: Spellings found in raw file headers -> pint expressions.
_ALIASES: dict[str, str] = {
    "": "dimensionless",
    "-": "dimensionless",
    "#": "dimensionless",
    "none": "dimensionless",
    "sec": "second",
    "secs": "second",
    "s": "second",
    "ms": "millisecond",
    "mph": "mile / hour",
    "kph": "kilometer / hour",
    "km/h": "kilometer / hour",
    "kmh": "kilometer / hour",
    "kmph": "kilometer / hour",
    "m/s": "meter / second",
    "mps": "meter / second",
    "m/s2": "meter / second ** 2",
    "m/s^2": "meter / second ** 2",
    "rpm": "revolution / minute",
    "rad/s": "radian / second",
    "c": "degC",
    "°c": "degC",
    "degc": "degC",
    "deg c": "degC",
    "f": "degF",
    "°f": "degF",
    "degf": "degF",
    "deg f": "degF",
    "k": "kelvin",
    "%": "percent",
    "pct": "percent",
    "percent": "percent",
    "nm": "newton * meter",
    "n.m": "newton * meter",
    "n*m": "newton * meter",
    "n-m": "newton * meter",
    "n·m": "newton * meter",
    "ft-lb": "foot * force_pound",
    "ftlb": "foot * force_pound",
    "lb-ft": "foot * force_pound",
    "lbft": "foot * force_pound",
    "lbf": "force_pound",
    "lb": "force_pound",
    "n": "newton",
    "kn": "kilonewton",
    "w": "watt",
    "kw": "kilowatt",
    "hp": "horsepower",
    "v": "volt",
    "a": "ampere",
    "ah": "ampere * hour",
    "wh": "watt * hour",
    "kwh": "kilowatt * hour",
    "j": "joule",
    "kj": "kilojoule",
    "mj": "megajoule",
    "g/s": "gram / second",
    "gps": "gram / second",
    "kg/s": "kilogram / second",
    "kg/h": "kilogram / hour",
    "g/h": "gram / hour",
    "l/h": "liter / hour",
    "ccps": "cubic_centimeter / second",
    "cc/s": "cubic_centimeter / second",
    "ml/s": "milliliter / second",
    "kpa": "kilopascal",
    "pa": "pascal",
    "bar": "bar",
    "mbar": "millibar",
    "psi": "psi",
    "inhg": "inch_Hg",
    "ohm": "ohm",
    "mohm": "milliohm",
    "kg": "kilogram",
    "g": "gram",
    "m": "meter",
    "km": "kilometer",
    "mi": "mile",
    "rad": "radian",
    "deg": "degree",
}

#: The pint expressions of the spellings above: known units, so a conversion between two
#: spellings of the same one is the identity without consulting the registry.
_KNOWN = frozenset(_ALIASES.values())


def _expression(text: str | None) -> str:
    raw = "" if text is None else str(text).strip()
    return _ALIASES.get(raw.lower(), raw)


@lru_cache(maxsize=1)
def _rate_dimensions() -> tuple[Any, Any]:
    """Dimensionality of a volumetric flow and of a mass flow."""
    reg = registry()
    return (reg.Unit("meter ** 3 / second").dimensionality,
            reg.Unit("kilogram / second").dimensionality)


@lru_cache(maxsize=512)
def parse_unit(text: str | None) -> pint.Unit:
    """Parse a unit as written in a file header or template.

    Parameters
    ----------
    text : str or None
        e.g. ``"mph"``, ``"rpm"``, ``"°F"``, ``"g/s"``, ``"N.m"``; ``None`` or ``""`` is
        dimensionless.

    Raises
    ------
    UnitError
        When the unit is unknown to the registry, with a hint.
    """
    raw = "" if text is None else str(text).strip()
    expr = _expression(raw)
    try:
        return registry().Unit(expr)
    except Exception as exc:  # pint raises several types (and OverflowError, RecursionError)
        raise UnitError(
            f"unknown unit '{raw}': use a pint unit expression (for example 'mph', 'rpm', "
            f"'degF', 'g/s', 'kW', 'N*m') or one of the header spellings vehval knows"
        ) from exc


def conversion(raw_unit: str | None, si_unit: str, *, fuel_density_kg_per_m3: float | None = None,
               ) -> tuple[float, float]:
    """Return ``(scale, offset)`` such that ``si = raw * scale + offset``.

    Volumetric fuel flow (e.g. ccps) converts to a mass rate with the fuel density.

    Parameters
    ----------
    raw_unit : str
        Unit of the raw samples.
    si_unit : str
        Target unit (the registry's SI unit of the signal).
    fuel_density_kg_per_m3 : float, optional
        Density [kg/m^3] used for volume -> mass conversions.
    """
    try:
        scale, offset = _conversion(raw_unit, si_unit, fuel_density_kg_per_m3)
    except (OverflowError, ZeroDivisionError, _pint_error()) as exc:
        # e.g. 'Ym/ys*(Ym/ym)**20' (1e960 overflows), 'degC*(Ym/ym)**10' (an offset unit
        # times a factor is no temperature)
        why = "the factor overflows" if isinstance(exc, OverflowError) else str(exc)
        raise UnitError(f"cannot convert '{raw_unit}' to '{si_unit}': {why}: give a plain "
                        "unit such as 'mph', 'rpm', 'degF' or 'g/s'") from None
    if not (math.isfinite(scale) and math.isfinite(offset)) or scale == 0.0:
        raise UnitError(f"cannot convert '{raw_unit}' to '{si_unit}': the factor {scale:g} "
                        f"(offset {offset:g}) is not a usable finite number: give a plain unit "
                        "such as 'mph', 'rpm', 'degF' or 'g/s'")
    return scale, offset


def _conversion(raw_unit: str | None, si_unit: str, fuel_density_kg_per_m3: float | None,
                ) -> tuple[float, float]:
    expr = _expression(raw_unit)
    if expr in _KNOWN and expr == _expression(si_unit):
        return 1.0, 0.0
    src = parse_unit(raw_unit)
    dst = parse_unit(si_unit)
    ureg = registry()
    volumetric, mass_rate = _rate_dimensions()
    factor = 1.0
    if src.dimensionality == volumetric and dst.dimensionality == mass_rate:
        if not fuel_density_kg_per_m3:
            raise UnitError(
                f"converting volumetric '{raw_unit}' to '{si_unit}' needs the fuel density: "
                "declare the fuel in the template ('fuel: diesel', a name of the fuel table, "
                "or constants.fuel_density_kg_per_m3)")
        factor = float(fuel_density_kg_per_m3)
        q0 = ureg.Quantity(0.0, src).to("meter ** 3 / second").magnitude
        q1 = ureg.Quantity(1.0, src).to("meter ** 3 / second").magnitude
        return (q1 - q0) * factor * ureg.Quantity(1.0, "kg/s").to(dst).magnitude, 0.0
    if src.dimensionality != dst.dimensionality:
        raise UnitError(
            f"cannot convert '{raw_unit}' ({src.dimensionality}) to '{si_unit}' "
            f"({dst.dimensionality}): check the raw unit in the template")
    q0 = ureg.Quantity(0.0, src).to(dst).magnitude
    q1 = ureg.Quantity(1.0, src).to(dst).magnitude
    return float(q1 - q0), float(q0)


def to_si(values: np.ndarray, raw_unit: str | None, si_unit: str, **kwargs: float | None,
          ) -> np.ndarray:
    """Convert an array from ``raw_unit`` to ``si_unit`` (affine, so °F/°C work)."""
    scale, offset = conversion(raw_unit, si_unit, **kwargs)
    out = np.asarray(values, dtype=float) * scale
    if offset:
        out = out + offset
    return out


def from_si(values: np.ndarray, si_unit: str, raw_unit: str | None, **kwargs: float | None,
            ) -> np.ndarray:
    """Inverse of :func:`to_si`: convert SI samples to ``raw_unit`` for export."""
    scale, offset = conversion(raw_unit, si_unit, **kwargs)
    return (np.asarray(values, dtype=float) - offset) / scale


_HEADER = re.compile(r"^(?P<name>.*?)\s*[\[(](?P<unit>[^\])]*)[\])]\s*$")


def split_header(header: str) -> tuple[str, str | None]:
    """Split ``'Dyno_Speed[mph]'`` or ``'Speed (kph)'`` into name and unit (``None`` if absent)."""
    m = _HEADER.match(header.strip())
    if not m:
        return header.strip(), None
    return m.group("name").strip(), m.group("unit").strip()
