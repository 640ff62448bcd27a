"""The signal nomenclature registry, loaded from ``data/signals.yaml``.

Full names are ``<base>[_<source>]_<origin>``: ``eng_spd_out_obd_test`` has base
``eng_spd_out``, source ``obd`` and origin ``test``. The base name fixes the quantity,
SI unit, category, plausible range and resampling method.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Literal

from vehval.errors import SignalError
from vehval.safe_yaml import load_yaml

ResampleMethod = Literal["linear", "previous"]
ORIGINS = ("test", "calc", "simu")

#: Source qualifiers of the facility's own instrumentation, in order of preference (after
#: no qualifier at all, the facility's main sensor).
FACILITY_QUALIFIERS = ("daq", "direct", "bench", "modal", "dyno", "pa")
#: Vehicle-network sources, trusted after the facility's sensors.
NETWORK_QUALIFIERS = ("obd", "can", "ecu")


@dataclass(frozen=True)
class SignalSpec:
    """One base name of the registry.

    Attributes
    ----------
    base : str
        Base name, e.g. ``eng_spd_out``.
    unit : str
        SI unit as a pint expression, e.g. ``rad/s``.
    category : str
        Component category (engine, motor, battery...).
    description : str
        One line of plain text.
    range : tuple of float
        Plausible ``(min, max)`` in SI.
    resample : {'linear', 'previous'}
        Method for resampling to another time grid.
    aliases : tuple of str
        Normalised raw names that map to this base name.
    """

    base: str
    unit: str
    category: str
    description: str
    range: tuple[float, float]
    resample: ResampleMethod
    aliases: tuple[str, ...]


@dataclass(frozen=True)
class SignalName:
    """A parsed full signal name."""

    base: str
    source: str | None
    origin: str

    @property
    def full(self) -> str:
        parts = [self.base] + ([self.source] if self.source else []) + [self.origin]
        return "_".join(parts)


def normalise_raw(name: str) -> str:
    """Normalise a raw channel name for alias matching (lower case, single spaces)."""
    text = re.sub(r"[_\s]+", " ", name.strip().lower())
    return text


class Registry:
    """The nomenclature registry (read-only)."""

    def __init__(self, data: dict) -> None:
        self.version: int = int(data.get("version", 1))
        self.sources: tuple[str, ...] = tuple(data.get("sources", ()))
        self.categories: tuple[str, ...] = tuple(data.get("categories", ()))
        self.specs: dict[str, SignalSpec] = {}
        self._alias: dict[str, str] = {}
        for base, entry in data["signals"].items():
            spec = SignalSpec(
                base=base,
                unit=str(entry["unit"]),
                category=str(entry["category"]),
                description=str(entry["description"]),
                range=(float(entry["range"][0]), float(entry["range"][1])),
                resample=entry.get("resample", "linear"),
                aliases=tuple(normalise_raw(a) for a in entry.get("aliases", []) or []),
            )
            if spec.category not in self.categories:
                raise ValueError(f"signals.yaml: {base}: unknown category {spec.category!r}")
            self.specs[base] = spec
            for alias in spec.aliases:
                self._alias.setdefault(alias, base)

    def __contains__(self, base: str) -> bool:
        return base in self.specs

    def __getitem__(self, base: str) -> SignalSpec:
        return self.specs[base]

    def parse(self, full_name: str) -> SignalName:
        """Split a full name into base, source and origin.

        Raises
        ------
        SignalError
            When the name does not follow ``<base>[_<source>]_<origin>`` with a known base.
        """
        parts = full_name.split("_")
        if len(parts) < 2 or parts[-1] not in ORIGINS:
            raise SignalError(
                f"signal name '{full_name}' must end with one of _test, _calc, _simu "
                f"(nomenclature <component>_<quantity>[_<port>][_<source>]_<origin>)")
        origin = parts[-1]
        stem = "_".join(parts[:-1])
        if stem in self.specs:
            return SignalName(stem, None, origin)
        if len(parts) >= 3:
            base = "_".join(parts[:-2])
            if base in self.specs:
                return SignalName(base, parts[-2], origin)
        raise SignalError(
            f"signal name '{full_name}': base name '{stem}' is not in the registry; "
            "see `vehval signals` or docs/nomenclature.md for the list")

    def spec_of(self, full_name: str) -> SignalSpec:
        """The registry entry of a full signal name."""
        return self.specs[self.parse(full_name).base]

    def match_alias(self, raw_name: str) -> str | None:
        """Base name whose alias equals the normalised raw name, or ``None``."""
        return self._alias.get(normalise_raw(raw_name))


@lru_cache(maxsize=1)
def registry() -> Registry:
    """The package registry (loaded once)."""
    text = resources.files("vehval").joinpath("data/signals.yaml").read_text(encoding="utf-8")
    return Registry(load_yaml(text, "data/signals.yaml"))


def preference_rank(name: str) -> tuple[float, str]:
    """Which source to trust first when a quantity is measured several times (sort key).

    The one policy of the package: the facility sensor with no qualifier first, then the
    facility qualifiers (:data:`FACILITY_QUALIFIERS` in order), then the vehicle network
    (OBD/CAN/ECU), then anything else (targets, unknown qualifiers); ties by name. Names
    outside the nomenclature come last.
    """
    try:
        q = registry().parse(name).source
    except SignalError:
        return (9, name)
    if q is None:
        return (0, name)
    if q in FACILITY_QUALIFIERS:
        return (1 + FACILITY_QUALIFIERS.index(q) / 10, name)
    if q in NETWORK_QUALIFIERS:
        return (3, name)
    return (4, name)
