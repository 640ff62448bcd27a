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

from functools import cache
from importlib import resources

from vehval.errors import ConfigError
from vehval.safe_yaml import load_yaml

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
