"""Default sensor accuracies per signal class (``data/uncertainty/sensor_accuracy.yaml``).

A signal whose template declares no ``accuracy:`` gets the default of its class: first the
entry of its base name and source qualifier (``veh_spd/obd``: an OBD speed is no roll speed),
then its base name, else the fallback (1 % of reading). Each entry is a limit of error held
over the test: a gain limit in % of reading and a zero-offset limit in the signal's SI unit,
with one line of basis and its source (a regulation that bounds it, or "engineering default").
The results stage (:mod:`vehval.results.uncertainty`) and the QA levels 2 and 3
(:mod:`vehval.qa.uncertainty`) both take their defaults from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

from vehval.errors import ConfigError
from vehval.nomenclature import registry
from vehval.safe_yaml import load_yaml
from vehval.units import conversion

_PATH = "data/uncertainty/sensor_accuracy.yaml"

#: One default: reading limit [% of reading], offset limit [SI], basis (its source is in the
#: table beside it).
Default = tuple[float, float, str]


def _entry(key: str, e: object) -> Default:
    if not isinstance(e, dict):
        raise ConfigError(f"{_PATH}: entry '{key}' must be a mapping")
    try:
        pct, off = float(e["reading_pct"]), float(e["offset_si"])
        basis, source = str(e["basis"]), str(e["source"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"{_PATH}: entry '{key}' needs reading_pct, offset_si, basis and "
                          f"source ({exc})") from exc
    if min(pct, off) < 0:
        raise ConfigError(f"{_PATH}: entry '{key}': limits cannot be negative")
    if not source.strip():
        raise ConfigError(f"{_PATH}: entry '{key}' names no source")
    return pct, off, basis


@cache
def sensor_defaults() -> tuple[dict[str, Default], dict[tuple[str, str], Default], Default]:
    """``(by base, by (base, source), fallback)`` of the packaged table."""
    text = (resources.files("vehval") / "data" / "uncertainty" / "sensor_accuracy.yaml"
            ).read_text(encoding="utf-8")
    data = load_yaml(text, _PATH)
    classes = {k: _entry(k, v) for k, v in (data.get("classes") or {}).items()}
    sources: dict[tuple[str, str], Default] = {}
    for k, v in (data.get("sources") or {}).items():
        base, _, src = str(k).partition("/")
        if not src:
            raise ConfigError(f"{_PATH}: source entry '{k}' must be written base/source")
        sources[(base, src)] = _entry(k, v)
    return classes, sources, _entry("fallback", data.get("fallback"))


_SQRT3 = math.sqrt(3.0)


@dataclass(frozen=True)
class Parameter:
    """One uncertain input: a rectangular error of half-width ``limit`` around zero.

    ``kind`` is ``gain`` (relative, -), ``offset`` (in the signal's SI unit) or ``property``
    (absolute, in the property's unit).
    """

    name: str
    limit: float
    kind: str
    assumed: bool = False

    @property
    def std(self) -> float:
        return self.limit / _SQRT3


@dataclass(frozen=True)
class ChannelAccuracy:
    """Resolved accuracy of one signal: gain limit [-], offset limit [SI], provenance."""

    signal: str
    gain_limit: float
    offset_limit: float
    assumed: bool
    basis: str

    def parameters(self) -> list[Parameter]:
        out = []
        if self.gain_limit > 0:
            out.append(Parameter(f"{self.signal} reading", self.gain_limit, "gain", self.assumed))
        if self.offset_limit > 0:
            out.append(Parameter(f"{self.signal} offset", self.offset_limit, "offset",
                                 self.assumed))
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"reading_pct": round(self.gain_limit * 100, 6), "offset_si": self.offset_limit,
                "assumed": self.assumed, "basis": self.basis}


def channel_accuracy(signal: str, spec: Any | None) -> ChannelAccuracy:
    """The accuracy of ``signal``: the template's ``AccuracySpec`` or its class default."""
    name = registry().parse(signal)
    base = name.base
    if spec is None:
        classes, sources, fallback = sensor_defaults()
        pct, off, why = sources.get((base, name.source or ""), classes.get(base, fallback))
        return ChannelAccuracy(signal, pct / 100.0, off, True, f"assumed class default: {why}")
    unit = spec.unit
    si = registry().spec_of(signal).unit
    scale = 1.0
    if unit is not None:
        scale, _ = conversion(unit, si)
    fs = (spec.full_scale or 0.0) * spec.full_scale_pct / 100.0
    off = (fs + spec.offset) * abs(scale)
    basis = (f"template: {spec.reading_pct:g} % of reading"
             + (f", {spec.full_scale_pct:g} % of {spec.full_scale:g} {unit or si}" if fs else "")
             + (f", offset {spec.offset:g} {unit or si}" if spec.offset else ""))
    return ChannelAccuracy(signal, spec.reading_pct / 100.0, off, False, basis)
