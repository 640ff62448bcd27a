"""The fuel table: the packaged ``vehval/data/fuels.yaml``, one sourced property set per fuel.

This is the only place where fuel properties (density, lower heating value, carbon mass
fraction) live. A template or a vehicle file names a fuel of the table (``fuel: diesel``) or
gives explicit properties; :mod:`vehval.fuels.resolve` decides which applies. Nothing here
guesses a fuel: an unknown name is an error that lists the known ones.

Examples
--------
>>> f = fuel_properties("diesel")
>>> f.density_kg_per_m3, round(f.lhv_j_per_kg / 1e6, 2)
(851.0, 42.8)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from typing import Any

from vehval.errors import ConfigError
from vehval.safe_yaml import load_yaml

__all__ = ["PROPERTIES", "Fuel", "fuel_properties", "known_fuels", "table_fuel"]

#: The properties of a fuel (keys of the table and of a template's explicit ``fuel:``).
PROPERTIES = ("density_kg_per_m3", "lhv_j_per_kg", "carbon_mass_fraction")
_PROPS = PROPERTIES


@dataclass(frozen=True)
class Fuel:
    """Properties of a fuel.

    Attributes
    ----------
    name : str
        Table name (``diesel``) or ``explicit`` for properties given in the template.
    density_kg_per_m3 : float or None
        Density at 15 degC [kg/m^3].
    lhv_j_per_kg : float or None
        Lower heating value [J/kg].
    carbon_mass_fraction : float or None
        Mass of carbon per mass of fuel [-].
    uncertainty : dict
        Property -> half-width of its batch-to-batch spread (same unit as the value).
    sources : dict
        Property -> where the value comes from.
    """

    name: str
    density_kg_per_m3: float | None = None
    lhv_j_per_kg: float | None = None
    carbon_mass_fraction: float | None = None
    description: str = ""
    uncertainty: dict[str, float] = field(default_factory=dict)
    sources: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "description": self.description,
                **{p: getattr(self, p) for p in _PROPS},
                "uncertainty": dict(self.uncertainty), "sources": dict(self.sources)}


@lru_cache(maxsize=1)
def _table() -> dict[str, Fuel]:
    text = (resources.files("vehval") / "data" / "fuels.yaml").read_text(encoding="utf-8")
    data = load_yaml(text, "data/fuels.yaml")
    out = {}
    for name, entry in data["fuels"].items():
        vals = {p: float(entry[p]["value"]) for p in _PROPS}
        out[name] = Fuel(name=name, description=entry.get("description", ""), **vals,
                         uncertainty={p: float(entry[p].get("uncertainty", 0.0)) for p in _PROPS},
                         sources={p: str(entry[p]["source"]) for p in _PROPS})
    return out


def known_fuels() -> list[str]:
    """Names of the fuels in the packaged table, sorted."""
    return sorted(_table())


def _key(name: str) -> str:
    return str(name).strip().lower().replace("-", "_").replace(" ", "_")


def table_fuel(name: str) -> Fuel:
    """The table entry ``name`` (case-insensitive).

    Raises
    ------
    ConfigError
        Unknown fuel name (the message lists the known ones).
    """
    base = _table().get(_key(name))
    if base is None:
        raise ConfigError(f"fuel: unknown fuel '{name}': known fuels are "
                          f"{', '.join(known_fuels())}, or give density_kg_per_m3, "
                          "lhv_j_per_kg and carbon_mass_fraction explicitly")
    return base


def fuel_properties(spec: str | dict | Any | None) -> Fuel | None:
    """Resolve a template's ``fuel:`` entry.

    Parameters
    ----------
    spec : str, dict, pydantic model or None
        A table name (case-insensitive), or explicit ``density_kg_per_m3`` [kg/m^3],
        ``lhv_j_per_kg`` [J/kg], ``carbon_mass_fraction`` [-] (any may be left out; a
        ``name`` key picks a table entry whose values the explicit ones override).

    Returns
    -------
    Fuel or None
        None when ``spec`` is None (no fuel declared).

    Raises
    ------
    ConfigError
        Unknown fuel name (the message lists the known ones).
    """
    if spec is None:
        return None
    if hasattr(spec, "model_dump"):
        spec = spec.model_dump(exclude_none=True)
    if isinstance(spec, str):
        spec = {"name": spec}
    name = spec.get("name")
    base = None
    if name is not None:
        base = table_fuel(str(name))
    explicit = {p: float(spec[p]) for p in _PROPS if spec.get(p) is not None}
    if base is None:
        return Fuel(name="explicit", description="properties given in the template",
                    **explicit, uncertainty={p: 0.0 for p in explicit},
                    sources={p: "template" for p in explicit})
    vals = {p: explicit.get(p, getattr(base, p)) for p in _PROPS}
    unc = {p: (0.0 if p in explicit else base.uncertainty.get(p, 0.0)) for p in _PROPS}
    src = {p: ("template" if p in explicit else base.sources[p]) for p in _PROPS}
    return Fuel(name=base.name, description=base.description, **vals, uncertainty=unc,
                sources=src)


#: Density of a liquid road fuel [kg/m^3]: LPG (about 510) to biodiesel (about 880) with
#: margin. A value outside is a unit slip (g/cm^3 is x1000, a missing digit x10), refused.
LIQUID_DENSITY_RANGE = (450.0, 1100.0)


def density_problem(key: str, value: float | None) -> str | None:
    """Why ``value`` [kg/m^3] given as ``key`` is no liquid fuel's density, naming the
    probable unit slip; None when it is plausible (or not given)."""
    if value is None:
        return None
    lo, hi = LIQUID_DENSITY_RANGE
    if lo <= value <= hi:
        return None
    guesses = [(f, why) for f, why in ((1000.0, "g/cm3 or kg/L"), (10.0, "a digit missing"),
                                       (0.1, "a digit too many"), (0.001, "g/m3"))
               if lo <= value * f <= hi]
    hint = (f": probably {guesses[0][1]}, i.e. {value * guesses[0][0]:g} kg/m3"
            if guesses else "")
    return (f"{key}: {value:g} kg/m3 is no liquid fuel's density ({lo:g}-{hi:g} kg/m3, LPG to "
            f"biodiesel){hint}; give it in kg/m3 (diesel about 851, gasoline about 740)")
