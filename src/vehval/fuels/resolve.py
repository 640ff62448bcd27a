"""The one fuel resolver: which fuel a test ran on, and where that came from.

Every command and stage (import, QA calculations, results, batch metrics, validation,
identification, ``template check``) asks :func:`resolve_fuel`; nothing else decides a fuel.
The order:

1. the template's ``fuel:`` key (a table name or explicit properties; kept in the test's
   metadata at import as ``meta.fuel``);
2. explicit constants ``fuel_density_kg_per_m3`` / ``fuel_lhv_j_per_kg`` (explicit
   ``constants`` given by the caller, then the test's, then the template's); a property they
   leave out is the vehicle's (density and LHV only: no carbon fraction, so no CO2);
3. the vehicle file's engine: its ``fuel`` (a table name) with any explicit values it gives
   over the table's, or its explicit ``fuel_density_kg_per_m3`` / ``fuel_lhv_j_per_kg``.

There is no default fuel: with none of these the result is None, and a figure that needs a
fuel property is not computed (:func:`require` says what to declare).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from vehval.conditions import finite_number, vehicle_value
from vehval.errors import ConfigError
from vehval.fuels.table import PROPERTIES, Fuel, fuel_properties, table_fuel

__all__ = ["CONSTANT_KEYS", "ResolvedFuel", "require", "resolve_fuel", "vehicle_fuel"]

#: Fuel property -> template constant / vehicle ``engine.`` key that may give it explicitly.
CONSTANT_KEYS = {"density_kg_per_m3": "fuel_density_kg_per_m3",
                 "lhv_j_per_kg": "fuel_lhv_j_per_kg"}


@dataclass(frozen=True)
class ResolvedFuel:
    """A fuel and where it came from.

    Attributes
    ----------
    fuel : Fuel
        The properties (``density_kg_per_m3`` [kg/m^3], ``lhv_j_per_kg`` [J/kg],
        ``carbon_mass_fraction`` [-]; None where not known), their sources and uncertainty.
    origin : str
        ``template fuel``, ``template constants`` or ``vehicle <name>``.
    """

    fuel: Fuel
    origin: str

    @property
    def name(self) -> str:
        return self.fuel.name

    @property
    def density_kg_per_m3(self) -> float | None:
        return self.fuel.density_kg_per_m3

    @property
    def lhv_j_per_kg(self) -> float | None:
        return self.fuel.lhv_j_per_kg

    @property
    def carbon_mass_fraction(self) -> float | None:
        return self.fuel.carbon_mass_fraction

    @property
    def uncertainty(self) -> dict[str, float]:
        return self.fuel.uncertainty

    @property
    def sources(self) -> dict[str, str]:
        return self.fuel.sources

    def to_dict(self) -> dict[str, Any]:
        return {**self.fuel.to_dict(), "origin": self.origin}


def _number(value: Any) -> float | None:
    """A fuel property: a finite, positive number; else None."""
    f = finite_number(value)
    return f if f is not None and f > 0 else None


def _explicit(values: Mapping[str, float], sources: Mapping[str, str],
              base: Fuel | None = None) -> Fuel:
    """``base`` with ``values`` over it (or an ``explicit`` fuel of ``values`` alone)."""
    if base is None:
        return Fuel(name="explicit", description="explicit fuel properties", **values,
                    uncertainty={p: 0.0 for p in values}, sources=dict(sources))
    vals = {p: values.get(p, getattr(base, p)) for p in PROPERTIES}
    return Fuel(name=base.name, description=base.description, **vals,
                uncertainty={p: (0.0 if p in values else base.uncertainty.get(p, 0.0))
                             for p in PROPERTIES},
                sources={p: sources.get(p, base.sources.get(p, "")) for p in PROPERTIES})


def vehicle_fuel(vehicle: Any) -> Fuel | None:
    """The fuel of a vehicle file's engine: its table ``fuel`` with the explicit values that
    differ from the table's, or its explicit values alone; None without either."""
    if vehicle is None:
        return None
    name = vehicle_value(vehicle, "engine.fuel")
    srcs = vehicle_value(vehicle, "engine.sources") or {}
    base = table_fuel(str(name)) if name else None
    values: dict[str, float] = {}
    sources: dict[str, str] = {}
    for prop, key in CONSTANT_KEYS.items():
        v = _number(vehicle_value(vehicle, f"engine.{key}"))
        if v is None or (base is not None and v == getattr(base, prop)):
            continue
        values[prop] = v
        sources[prop] = f"vehicle engine.{key}: {srcs.get(key, 'no source given')}"
    if base is None and not values:
        return None
    return _explicit(values, sources, base)


def resolve_fuel(*, template: Any = None, test: Any = None,
                 constants: Mapping[str, Any] | None = None,
                 vehicle: Any = None) -> ResolvedFuel | None:
    """The test fuel, by the order of the module docstring.

    Parameters
    ----------
    template : Template, optional
        Its ``fuel`` and its constants.
    test : Test, optional
        Its ``meta.fuel`` (the template's ``fuel:`` kept at import) and ``meta.constants``.
    constants : mapping, optional
        Explicit constants (beat the test's and the template's).
    vehicle : Vehicle or mapping, optional
        Its ``engine.fuel`` / ``engine.fuel_density_kg_per_m3`` / ``engine.fuel_lhv_j_per_kg``.

    Returns
    -------
    ResolvedFuel or None

    Raises
    ------
    ConfigError
        A fuel name not in the table.
    """
    meta = getattr(test, "meta", None)
    spec = getattr(template, "fuel", None)
    if spec is None and meta is not None:
        spec = getattr(meta, "fuel", None)
    if spec:
        fuel = fuel_properties(spec)
        if fuel is not None:
            return ResolvedFuel(fuel, "template fuel")
    merged: dict[str, Any] = {}
    if template is not None and hasattr(template, "constants_dict"):
        merged.update(template.constants_dict())
    if meta is not None:
        merged.update(getattr(meta, "constants", None) or {})
    merged.update(constants or {})
    values = {p: v for p, k in CONSTANT_KEYS.items() if (v := _number(merged.get(k))) is not None}
    vf = vehicle_fuel(vehicle)
    label = getattr(vehicle, "name", None) or "file"
    if values:
        sources = {p: f"template constant {CONSTANT_KEYS[p]}" for p in values}
        for p in CONSTANT_KEYS:  # a property the constants leave out: the vehicle's, per value
            if p not in values and vf is not None and getattr(vf, p) is not None:
                values[p] = getattr(vf, p)
                sources[p] = f"vehicle {label} engine.{CONSTANT_KEYS[p]}"
        return ResolvedFuel(_explicit(values, sources), "template constants")
    if vf is not None:
        return ResolvedFuel(vf, f"vehicle {label}")
    return None


def require(fuel: ResolvedFuel | Fuel | None, prop: str, what: str) -> float:
    """The property ``prop`` of ``fuel``, or a ConfigError saying how to declare it.

    Parameters
    ----------
    fuel : ResolvedFuel, Fuel or None
    prop : {'density_kg_per_m3', 'lhv_j_per_kg', 'carbon_mass_fraction'}
    what : str
        What needs it (starts the message: ``identify``, ``ccps flow``...).
    """
    v = getattr(fuel, prop, None) if fuel is not None else None
    if v is None:
        have = f"the fuel ({getattr(fuel, 'origin', 'declared')}) gives no {prop}" if fuel \
            else "no fuel is declared"
        raise ConfigError(f"{what} needs the fuel {prop}: {have}; declare the fuel in the "
                          "template ('fuel: diesel', a name of the fuel table, or "
                          f"constants.{CONSTANT_KEYS.get(prop, prop)})")
    return float(v)
