"""What the workflow needs of a vehicle and of a template (structural types, no import of
the implementations): :class:`vehval.vehicle.Vehicle` / ``ConventionalVehicle`` and
:class:`vehval.io.template.Template` satisfy them."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable


@runtime_checkable
class VehicleLike(Protocol):
    """A vehicle model: a name, its file, parameter blocks reached by dotted path
    (``body.mass_kg``, ``engine.fuel_lhv_j_per_kg``...)."""

    name: str

    @property
    def file(self) -> str | None: ...

    @property
    def body(self) -> Any: ...

    @property
    def engine(self) -> Any: ...

    @property
    def driveline(self) -> Any: ...


@runtime_checkable
class TemplateLike(Protocol):
    """An import template: its files, its constants and the vehicle it names."""

    files: list[Any]
    vehicle: str | None

    def constants_dict(self) -> dict[str, float]: ...
