"""Generic technology coefficients of a car built from its list row (a data file with provenance).

A Test Car List row states weight, road load, ratios, displacement and power; it does not
state the engine's efficiency, its friction or its idle fuel. :func:`vehicle_from_specs
<vehval.epa.specs.vehicle_from_specs>` takes them from a small set of coefficients per
**technology**, each with a physical meaning, read from
``vehval/data/epa/technology_coefficients.yaml`` (:func:`load_coefficients`):

* engine technology (:func:`engine_technology`): ``spark_na`` (naturally aspirated spark
  ignition) or ``spark_turbo`` (turbocharged). The lists have no aspiration column: a
  rated power at or above ``turbo_min_specific_power_w_per_l`` per litre (78 kW/L, as the fleet report's aspiration; the
  naturally aspirated engines of the 2016-2019 lists sit at 45-75 kW/L, the downsized
  turbo engines at 80-140) marks a turbocharged engine; a car built for its diesel rows
  has the ``diesel`` technology (compression ignition, turbocharged: no throttle, so no
  part-load pumping, a lean full load, its own efficiency, friction and idle;
  :attr:`vehval.epa.specs.Specs.engine_technology`);
* per engine technology: ``indicated_efficiency`` (slope of the Willans line at the
  reference specific power of 60 kW/L, [-]) and ``efficiency_specific_power_exponent``
  (gamma: the efficiency scales as (specific power / 60 kW/L)^-gamma; an engine built for
  more power per litre has a lower compression ratio against knock, turbocharged or not,
  more valve overlap and a richer calibration, and burns more at the part loads of a
  drive cycle), :func:`indicated_efficiency`),
  ``friction_scale`` (factor on Heywood's friction MEP, which with it carries the part-load
  pumping, [-]) and ``idle_factor`` (warm idle fuel / the Willans map at idle speed and
  the accessory load [-]: the idle control's retarded spark and its own air flow burn
  more than the Willans line; 1.73 on the one car measured, the D3 Camry) and
  ``pumping_bar`` (part-load pumping MEP of the throttle at zero load [bar], falling to 0
  at full load: :func:`vehval.epa.engine_model.pumping_mep_pa`) and ``accessory_power_w``
  (the electrical and mechanical accessories on the engine during the test [W]; 300 W,
  the generic value of :mod:`vehval.epa.specs`, when absent);
* per transmission family (:mod:`vehval.epa.transmissions`): ``efficiency`` of the gearbox
  and ``upshift_scale`` (factor on the family's upshift engine speeds: the automatic's
  1300 rpm after the upshift, the CVT's operating line, the manual's shift speeds; the
  shift strategy: 1 when absent).

Every value carries ``value``, ``interval`` (the fit's interval, or the range of its
source), ``source`` and, when fitted, ``fit`` (list year fitted on, rows, method); the file
header names the fit. A value absent from the file keeps the generic constant.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Sequence

from vehval.errors import ConfigError

ENGINE_TECHNOLOGIES = ("spark_na", "spark_turbo", "diesel")
#: How text names each engine technology
ENGINE_TECHNOLOGY_TEXT = {"spark_na": "naturally aspirated spark-ignition",
                          "spark_turbo": "turbocharged spark-ignition", "diesel": "diesel"}
ENGINE_KEYS = ("indicated_efficiency", "friction_scale", "idle_factor", "pumping_bar",
               "efficiency_specific_power_exponent", "accessory_power_w")
#: specific power at which ``indicated_efficiency`` holds [W/L]
REFERENCE_SPECIFIC_POWER_W_PER_L = 60e3
#: physical bounds of each coefficient (a file outside them is refused)
BOUNDS = {"indicated_efficiency": (0.2, 0.6), "friction_scale": (0.2, 4.0),
          "idle_factor": (0.5, 4.0), "pumping_bar": (0.0, 1.5), "efficiency": (0.7, 1.0),
          "upshift_scale": (0.7, 2.5), "accessory_power_w": (0.0, 3000.0),
          "efficiency_specific_power_exponent": (-1.0, 1.0),
          "turbo_min_specific_power_w_per_l": (30e3, 150e3)}
DEFAULT_FILE = "data/epa/technology_coefficients.yaml"
#: the package's fits of other list years (``--cross-year`` of ``epa fleet``), beside the default
PACKAGED_FITS = (DEFAULT_FILE, "data/epa/technology_coefficients_fit2019.yaml")


@dataclass(frozen=True)
class Coefficient:
    """One coefficient: value, interval [lo, hi], source text, fit note ('' when sourced)."""

    value: float
    interval: tuple[float, float]
    source: str
    fit: str = ""

    def text(self) -> str:
        """Source text for a vehicle file."""
        lo, hi = self.interval
        fit = f"; {self.fit}" if self.fit else ""
        return f"{self.source} (interval {lo:.4g}-{hi:.4g}{fit})"


@dataclass(frozen=True)
class Coefficients:
    """The coefficients file read (see the module docstring)."""

    engine: dict[str, dict[str, Coefficient]]
    transmission: dict[str, dict[str, Coefficient]]
    turbo_min_specific_power_w_per_l: float = 78e3
    where: str = DEFAULT_FILE
    header: dict[str, Any] = field(default_factory=dict)

    @property
    def fit_lists(self) -> tuple[str, ...]:
        """File names of the lists the values were fitted on (provenance ``fit_lists``):
        a row of one of them is in-sample."""
        raw = self.header.get("fit_lists") or ()
        return tuple(str(x) for x in ([raw] if isinstance(raw, str) else raw))

    @property
    def label(self) -> str:
        """The file and what it was fitted on, for a record."""
        fit = ", ".join(self.fit_lists) or "no list"
        return f"{Path(self.where).name} (fitted on {fit})"

    @functools.cached_property
    def digest(self) -> str:
        """Hash of every value (a changed file gives a new digest)."""
        import hashlib

        text = repr((sorted((t, sorted(v.items())) for t, v in self.engine.items()),
                     sorted((t, sorted(v.items())) for t, v in self.transmission.items()),
                     self.turbo_min_specific_power_w_per_l))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def engine_value(self, tech: str, key: str) -> Coefficient | None:
        return self.engine.get(tech, {}).get(key)

    def transmission_value(self, family: str, key: str) -> Coefficient | None:
        return self.transmission.get(family, {}).get(key)


def engine_technology(rated_power_w: float, displacement_l: float,
                      coefficients: Coefficients | None = None) -> str:
    """``spark_turbo`` when the specific power reaches the turbo threshold, else ``spark_na``."""
    c = coefficients or load_coefficients()
    spec = rated_power_w / max(displacement_l, 1e-9)
    return "spark_turbo" if spec >= c.turbo_min_specific_power_w_per_l else "spark_na"


def indicated_efficiency(base: float, exponent: float, rated_power_w: float,
                         displacement_l: float) -> float:
    """Indicated efficiency [-] of an engine of this specific power: ``base`` x (specific
    power / ``REFERENCE_SPECIFIC_POWER_W_PER_L``)^-``exponent``."""
    spec = rated_power_w / max(displacement_l, 1e-9)
    return base * (spec / REFERENCE_SPECIFIC_POWER_W_PER_L) ** (-exponent)


def engine_values(coef: Coefficients | None, engine_tech: str, rated_power_w: float,
                  displacement_l: float, eta: float | None, friction_scale: float | None,
                  eta_default: float, accessory_default_w: float = 300.0
                  ) -> dict[str, tuple[float, str]]:
    """(value, source text) of the engine's fuel coefficients: a given value as given (no
    source text), else the file's (``coef``; None: the generic defaults, ''); the
    indicated efficiency at this engine's specific power (:func:`indicated_efficiency`)
    unless given."""

    def pick(given: float | None, key: str, default: float) -> tuple[float, str]:
        if given is not None:
            return float(given), ""
        c = coef.engine_value(engine_tech, key) if coef is not None else None
        if c is None or coef is None:
            return default, ""
        return c.value, f"{key.replace('_', ' ')} of {engine_tech}: {c.text()} ({coef.where})"

    out = {"indicated_efficiency": pick(eta, "indicated_efficiency", eta_default),
           "friction_scale": pick(friction_scale, "friction_scale", 1.0),
           "idle_factor": pick(None, "idle_factor", 1.0),
           "pumping_bar": pick(None, "pumping_bar", 0.0),
           "accessory_power_w": pick(None, "accessory_power_w", accessory_default_w)}
    gamma, gamma_src = pick(None, "efficiency_specific_power_exponent", 0.0)
    if gamma and eta is None:
        base, src = out["indicated_efficiency"]
        spec = rated_power_w / max(displacement_l, 1e-9)
        out["indicated_efficiency"] = (
            indicated_efficiency(base, gamma, rated_power_w, displacement_l),
            f"{src}, at {spec / 1e3:.1f} kW/L x (specific power / "
            f"{REFERENCE_SPECIFIC_POWER_W_PER_L / 1e3:g} kW/L)^-{gamma:.4g}: {gamma_src}")
    return out


def _coefficient(raw: Any, where: str, key: str) -> Coefficient:
    if not isinstance(raw, dict) or "value" not in raw:
        raise ConfigError(f"{where}: '{key}' needs a mapping with 'value', 'interval', 'source'")
    try:
        value = float(raw["value"])
        lo, hi = (float(x) for x in raw.get("interval", (value, value)))
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: '{key}': value and interval must be numbers") from None
    name = key.rsplit(".", 1)[-1]
    b_lo, b_hi = BOUNDS.get(name, (-math.inf, math.inf))
    if not (math.isfinite(value) and b_lo <= value <= b_hi and lo <= value <= hi):
        raise ConfigError(f"{where}: '{key}' = {value:g} outside {b_lo:g}-{b_hi:g} or its "
                          f"interval {lo:g}-{hi:g}")
    return Coefficient(value, (lo, hi), str(raw.get("source", "")), str(raw.get("fit", "")))


def parse_coefficients(data: Any, where: str) -> Coefficients:
    """Coefficients from the parsed YAML ``data`` (``where`` names the file in errors)."""
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: not a mapping of technology coefficients")
    groups: dict[str, dict[str, dict[str, Coefficient]]] = {}
    for part in ("engine", "transmission"):
        groups[part] = {}
        for tech, values in (data.get(part) or {}).items():
            if not isinstance(values, dict):
                raise ConfigError(f"{where}: '{part}.{tech}' must be a mapping")
            groups[part][str(tech)] = {str(k): _coefficient(v, where, f"{part}.{tech}.{k}")
                                       for k, v in values.items()}
    turbo = data.get("turbo_min_specific_power_w_per_l", 78e3)
    c = _coefficient({"value": turbo}, where, "turbo_min_specific_power_w_per_l")
    return Coefficients(engine=groups["engine"], transmission=groups["transmission"],
                        turbo_min_specific_power_w_per_l=c.value, where=where,
                        header=dict(data.get("provenance") or {}))


_CACHE: dict[str, Coefficients] = {}


def load_coefficients(path: str | Path | None = None) -> Coefficients:
    """The technology coefficients of ``path`` (default: the package's file), cached."""
    from vehval.safe_yaml import read_yaml

    key = str(path) if path is not None else ""
    if key not in _CACHE:
        _CACHE[key] = (_packaged(DEFAULT_FILE) if path is None
                       else parse_coefficients(read_yaml(path), str(path)))
    return _CACHE[key]


def _packaged(name: str) -> Coefficients:
    from vehval.safe_yaml import load_yaml

    text = resources.files("vehval").joinpath(name).read_text(encoding="utf-8")
    return parse_coefficients(load_yaml(text, name), name)


def packaged_fits() -> list[Coefficients]:
    """The package's fits (:data:`PACKAGED_FITS`), each fitted on one list year."""
    return [load_coefficients() if n == DEFAULT_FILE else _packaged(n) for n in PACKAGED_FITS]


def for_list(list_name: str, choices: Sequence[Coefficients]) -> tuple[Coefficients, bool]:
    """The coefficients to judge the rows of ``list_name`` with: the first of ``choices`` not
    fitted on that list (out-of-sample), else the first; and whether the rows are in-sample."""
    for c in choices:
        if list_name not in c.fit_lists:
            return c, False
    return choices[0], True


__all__ = ["Coefficient", "Coefficients", "ENGINE_TECHNOLOGIES", "PACKAGED_FITS",
           "engine_technology", "engine_values", "for_list", "indicated_efficiency",
           "load_coefficients", "packaged_fits", "parse_coefficients"]
