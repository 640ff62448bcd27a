"""The package's single pint registry and SI conversion helpers.

Units are converted once, at import and at export; everything inside is SI floats.

What pint says about a unit (its dimension) and a conversion (scale and offset) is kept
on disk between runs, so that a command whose units were all seen before does not import
pint (0.3 s) nor build its registry (0.15 s): one JSON file per pint version and version
of this module, in ``$VEHVAL_CACHE_DIR/units``, else ``~/.cache/vehval/units``. Only answers
are kept (an unknown unit asks pint again, for its message); the file is replaced
atomically and a damaged or unwritable one is ignored. When a version's file is created, the
files of the other versions in that directory are removed, with the temporary files of
writers that died (only names this module writes; a failure to remove is ignored).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import sys
import tempfile
import threading
import time
from functools import lru_cache
from pathlib import Path
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


# ----------------------------------------------------------------------- facts kept on disk
_FACTS_FORMAT = 1
_facts: dict[str, dict[str, Any]] | None = None
_facts_lock = threading.Lock()  # one writer at a time within a process (serve, batch threads)


@lru_cache(maxsize=1)
def _facts_name() -> str:
    from importlib.metadata import version

    h = hashlib.sha256(f"{_FACTS_FORMAT}|{version('pint')}|{sys.version}|".encode())
    h.update(Path(__file__).read_bytes())
    return f"{h.hexdigest()[:16]}.json"


#: Answers kept on disk at most: beyond, new ones serve their process only.
MAX_FACTS = 4096


def facts_path() -> Path:
    """The file of facts of this pint version and this module's source (module docstring)."""
    env = os.environ.get("VEHVAL_CACHE_DIR")
    return (Path(env) if env else Path.home() / ".cache" / "vehval") / "units" / _facts_name()


#: Names this module writes in its directory: a version's file, and a file being written.
_FACTS_FILE = re.compile(r"[0-9a-f]{16}\.json")
_TMP_PREFIX, _TMP_SUFFIX = ".units-", ".tmp"
#: Age [s] beyond which a temporary file is a dead writer's (a write takes milliseconds).
STALE_TMP_S = 3600.0


def _remove_other_versions(path: Path | None = None) -> list[str]:
    """Remove the fact files of other versions next to ``path`` (default :func:`facts_path`)
    and temporary files older than :data:`STALE_TMP_S`; returns the names removed.

    Only regular files named as this module names them are touched. A file another process
    removed first, or one that cannot be removed, is skipped: never an error.
    """
    path = facts_path() if path is None else path
    removed: list[str] = []
    try:
        entries = list(os.scandir(path.parent))
    except OSError:
        return removed
    now = time.time()
    for entry in entries:
        name = entry.name
        try:
            if name == path.name or not entry.is_file(follow_symlinks=False):
                continue
            if name.startswith(_TMP_PREFIX) and name.endswith(_TMP_SUFFIX):
                if now - entry.stat(follow_symlinks=False).st_mtime < STALE_TMP_S:
                    continue  # another process is writing it
            elif not _FACTS_FILE.fullmatch(name):
                continue  # not the cache's
            os.unlink(entry.path)
            removed.append(name)
        except OSError:
            pass  # removed by another process meanwhile, or not ours to remove
    return removed


def _load_facts() -> dict[str, dict[str, Any]]:
    global _facts
    if _facts is None:
        _facts = {"conversion": {}, "dimension": {}}
        try:
            data = json.loads(facts_path().read_text(encoding="utf-8"))
            conv, dims = data["conversion"], data["dimension"]
            if all(isinstance(v, list) and len(v) == 2 and all(
                    isinstance(x, float) and math.isfinite(x) for x in v) for v in conv.values()) \
                    and all(isinstance(v, list) and all(
                        isinstance(d, list) and len(d) == 2 and isinstance(d[0], str)
                        and isinstance(d[1], (int, float)) for d in v) for v in dims.values()):
                _facts = {"conversion": conv, "dimension": dims}
        except (OSError, ValueError, TypeError, KeyError, AttributeError):
            pass  # no file yet, or not ours: start afresh
    return _facts


def _keep_fact(kind: str, key: str, value: Any) -> None:
    """Add one answer and replace the file atomically (any failure: kept in memory only)."""
    with _facts_lock:
        facts = _load_facts()
        facts[kind][key] = value
        if sum(len(v) for v in facts.values()) > MAX_FACTS:
            return  # a file that only grows (odd units, many densities): keep it in memory
        try:
            path = facts_path()
            path.parent.mkdir(parents=True, exist_ok=True)
            created = not path.exists()
            fd, tmp = tempfile.mkstemp(prefix=_TMP_PREFIX, suffix=_TMP_SUFFIX, dir=path.parent)
            try:
                with os.fdopen(fd, "w", encoding="utf-8") as f:
                    json.dump(facts, f)
                os.replace(tmp, path)
            except BaseException:
                os.unlink(tmp)
                raise
        except (OSError, TypeError, ValueError):
            return  # not written: the answer serves this process only
        if created:  # a new version's file: the earlier versions' are of no more use
            _remove_other_versions(path)


def dimension(text: str | None) -> tuple[tuple[str, float], ...]:
    """The dimension of a unit as sorted ``(base dimension, exponent)`` pairs: ``()`` for a
    dimensionless unit; two units measure the same quantity when their dimensions are equal.

    Raises
    ------
    UnitError
        When the unit is unknown (see :func:`parse_unit`).
    """
    key = _expression(text)
    got = _load_facts()["dimension"].get(key)
    if got is None:
        got = sorted([str(k), v] for k, v in dict(parse_unit(text).dimensionality).items())
        _keep_fact("dimension", key, got)
    return tuple((str(k), v) for k, v in got)


def is_dimensionless(text: str | None) -> bool:
    """True when the unit has no dimension (as ``parse_unit(text).dimensionless``)."""
    return dimension(text) == ()


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


def is_volume_rate(unit: str | None) -> bool:
    """True when ``unit`` is a volume flow (``ccps``, ``L/h``...): the channel measures the
    fuel's volume, its mass rests on the density it was imported with. False for any other
    unit, none, or one the registry does not know."""
    if not unit:
        return False
    try:
        return parse_unit(unit).dimensionality == _rate_dimensions()[0]
    except UnitError:
        return False


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
    if _identity(raw_unit, si_unit):
        return 1.0, 0.0
    key = json.dumps([raw_unit, si_unit, fuel_density_kg_per_m3], default=repr)
    known = _load_facts()["conversion"].get(key)
    if known is not None:
        return known[0], known[1]
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
    _keep_fact("conversion", key, [float(scale), float(offset)])
    return scale, offset


def _identity(raw_unit: str | None, si_unit: str) -> bool:
    """Two spellings of the same known unit: the identity, without the registry."""
    expr = _expression(raw_unit)
    return expr in _KNOWN and expr == _expression(si_unit)


def _conversion(raw_unit: str | None, si_unit: str, fuel_density_kg_per_m3: float | None,
                ) -> tuple[float, float]:
    if _identity(raw_unit, si_unit):
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
