"""Vehicle definition: the parameter blocks of every component, loaded from YAML.

``load_vehicle("prius_2004")`` reads ``vehval/data/vehicles/prius_2004.yaml``; a path
works too. Unknown or missing keys, unsourced parameters, non-positive masses and
non-monotonic map breakpoints raise :class:`~vehval.errors.ConfigError` naming the key
and the file.
"""

from __future__ import annotations

import copy
from functools import cached_property
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, PrivateAttr, ValidationError, model_validator

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.errors import ConfigError
from vehval.safe_yaml import read_yaml
from vehval.vehicle.base import apply_overrides, check_soc_target, validation_text
from vehval.vehicle.bev import BatteryElectricVehicle
from vehval.vehicle.components import (
    BatteryParams,
    BodyParams,
    BoostParams,
    DrivelineParams,
    EngineParams,
    MachineParams,
    PlanetaryParams,
)
from vehval.vehicle.control import ControllerParams, DriverParams
from vehval.vehicle.conventional import ConventionalVehicle
from vehval.vehicle.maps import best_efficiency_line
from vehval.vehicle.parallel import ParallelHybridVehicle
from vehval.vehicle.variant import resolve_variant

BLOCKS = ("body", "engine", "mg1", "mg2", "battery", "boost", "planetary", "driveline",
          "controller", "driver")


class Vehicle(BaseModel):
    """A complete vehicle: every component block plus controller and driver parameters."""

    model_config = ConfigDict(extra="forbid")

    architecture: Literal["power_split"] = "power_split"
    name: str
    description: str = ""
    body: BodyParams
    engine: EngineParams
    mg1: MachineParams
    mg2: MachineParams
    battery: BatteryParams
    boost: BoostParams
    planetary: PlanetaryParams
    driveline: DrivelineParams
    controller: ControllerParams
    driver: DriverParams
    variant_of: str | None = None
    """Base vehicle of a variant file (see :mod:`vehval.vehicle.variant`); None otherwise."""
    _file: str = PrivateAttr(default="")

    @property
    def file(self) -> str:
        """File the vehicle was loaded from ('' when built in code)."""
        return self._file

    @model_validator(mode="after")
    def _consistent(self):
        check_soc_target(self.controller.soc_target, self.battery)
        return self

    def parameters(self) -> dict[str, Any]:
        """Flat dict of every scalar parameter by dotted path (e.g. ``body.mass_kg``)."""
        out: dict[str, Any] = {}
        for blk in BLOCKS:
            for key, val in getattr(self, blk).model_dump(exclude={"sources"}).items():
                if isinstance(val, (int, float)):
                    out[f"{blk}.{key}"] = val
        return out

    def sources(self) -> dict[str, str]:
        """Source of every parameter by dotted path."""
        return {f"{blk}.{k}": v for blk in BLOCKS for k, v in getattr(self, blk).sources.items()}

    def with_overrides(self, overrides: dict[str, Any] | None) -> "Vehicle":
        """A validated copy with parameters replaced by dotted path (``controller.soc_target``).

        ``__`` may stand for ``.`` (``controller__soc_target``) so paths can be keyword names.
        """
        new = apply_overrides(self, overrides, BLOCKS)
        if new is not self:
            keys = {k.replace("__", ".") for k in overrides or ()}
            if keys & _BEST_LINE_KEYS:
                new.__dict__.pop("best_line", None)  # cached from the engine's maps
            elif "best_line" in self.__dict__:   # the same maps: the same line (no recompute)
                new.__dict__["best_line"] = self.__dict__["best_line"]
        return new

    def signal_limits(self) -> dict[str, tuple[float, float]]:
        """Physical limits per signal base name, SI units (for QA range checks)."""
        e, g1, g2, b, d = self.engine, self.mg1, self.mg2, self.battery, self.driveline
        v_max = (g2.max_speed_rpm * RPM * d.wheel_radius_m
                 / (d.final_drive_ratio * d.mg2_reduction_ratio))
        tmax = float(np.max(e.max_torque_nm))
        ring = self.planetary.ring_teeth / (self.planetary.ring_teeth + self.planetary.sun_teeth)
        return {
            "veh_spd": (0.0, v_max),
            "whl_spd": (0.0, v_max / d.wheel_radius_m),
            "eng_spd_out": (0.0, e.max_speed_rpm * RPM),
            "eng_trq_out": (-e.motoring_torque_nm, tmax),
            "eng_pwr_out": (-e.motoring_torque_nm * e.max_speed_rpm * RPM, e.max_power_w),
            "gen_spd_out": (-g1.max_speed_rpm * RPM, g1.max_speed_rpm * RPM),
            "gen_trq_out": (-g1.max_torque_nm, g1.max_torque_nm),
            "gen_pwr_out": (-g1.max_power_w, g1.max_power_w),
            "mot_spd_out": (-g2.max_speed_rpm * RPM, g2.max_speed_rpm * RPM),
            "mot_trq_out": (-g2.max_torque_nm, g2.max_torque_nm),
            "mot_pwr_out": (-g2.max_power_w, g2.max_power_w),
            "pg_trq_ring": (-tmax * ring, tmax * ring),
            "ess_soc": (b.soc_min, b.soc_max),
            "ess_pwr": (-float(np.max(b.charge_power_limit_w)),
                        float(np.max(b.discharge_power_limit_w))),
            "ess_volt": (0.0, float(np.max(b.ocv_v)) * 1.3),
            "boost_volt_out": (0.0, self.boost.volt_out_max_v),
            "fuel_rate": (0.0, float(np.max(e.fuel_rate_g_per_s)) * 1e-3),
        }

    @cached_property
    def best_line(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Engine best-efficiency line: power [W], speed [rad/s], torque [N·m]."""
        return best_efficiency_line(self.engine)


#: engine parameters the best-efficiency line is computed from
#: (:func:`vehval.vehicle.maps.best_efficiency_line`)
_BEST_LINE_KEYS = {f"engine.{k}" for k in (
    "speed_rpm", "torque_nm", "fuel_rate_g_per_s", "max_torque_nm", "idle_speed_rpm",
    "max_speed_rpm", "max_power_w")}


ARCHITECTURES: dict[str, type[Vehicle] | type[ConventionalVehicle]
                   | type[ParallelHybridVehicle] | type[BatteryElectricVehicle]] = {
    "power_split": Vehicle, "conventional": ConventionalVehicle,
    "parallel_hybrid": ParallelHybridVehicle, "battery_electric": BatteryElectricVehicle}

#: Signal categories (signals.yaml) a powertrain of each architecture does not have: a
#: template of that architecture may not map them and QA runs no check on them. The one
#: table of which signals an architecture lacks.
ABSENT_CATEGORIES: dict[str, tuple[str, ...]] = {
    "battery_electric": ("engine", "fuel", "generator", "planetary", "converter", "gearbox"),
    "conventional": ("generator", "planetary"),
    "parallel_hybrid": ("generator", "planetary"),
}
#: What a template of each architecture must map: alternatives of signal base names (one
#: alternative complete is enough).
REQUIRED_SIGNALS: dict[str, tuple[tuple[str, ...], ...]] = {
    "battery_electric": (("ess_volt", "ess_curr"), ("ess_pwr",)),
    "parallel_hybrid": (("ess_curr",), ("ess_pwr",)),
}

#: The relation set (``data/calculations/<name>.yaml``) QA runs on a test of each stated
#: architecture; one not listed (``power_split``) is chosen from the vehicle and signals.
CALC_SETS: dict[str, str] = {
    "conventional": "conventional", "battery_electric": "conventional",
    "parallel_hybrid": "parallel_hybrid",
}


def absent_categories(architecture: str | None) -> tuple[str, ...]:
    """Signal categories a car of ``architecture`` does not have (empty when unknown)."""
    return ABSENT_CATEGORIES.get(architecture or "", ())


def architecture_of(vehicle: Any = None, template: Any = None) -> str | None:
    """The tested car's architecture: the vehicle file's, else the template's
    ``architecture:``, else None (unknown)."""
    arch = getattr(vehicle, "architecture", None) or getattr(template, "architecture", None)
    return str(arch) if arch else None


def has_signal(base: str, architecture: str | None) -> bool:
    """Whether a car of ``architecture`` can have the signal ``base`` (False when its
    category is one the architecture lacks; True for an unknown signal or architecture)."""
    from vehval.nomenclature import registry

    reg = registry()
    return base not in reg or reg[base].category not in absent_categories(architecture)


def _foreign_key(data: dict, arch: str, model) -> str | None:
    """The first top-level key of ``data`` that belongs to another architecture only (an
    engine block in a battery-electric file...), or None."""
    own = set(model.model_fields)
    for key in data:
        if key in own:
            continue
        for other, m in ARCHITECTURES.items():
            if other != arch and key in m.model_fields:
                return f"key '{key}' belongs to a {other} vehicle, not a {arch} one: " \
                       f"remove it or change 'architecture'"
    return None


def _vehicles_dir() -> Path:
    return Path(str(resources.files("vehval") / "data" / "vehicles"))


def list_vehicles() -> list[str]:
    """Names of the vehicles shipped with vehval (those of a sub-folder named with it:
    ``bev/nissan_leaf_2016``)."""
    root = _vehicles_dir()
    return sorted(p.relative_to(root).with_suffix("").as_posix() for p in root.rglob("*.yaml"))


def _validate(data: Any, where: str):
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: a vehicle file must be a mapping of blocks "
                          f"({', '.join(BLOCKS)})")
    arch = data.get("architecture", "power_split")
    model = ARCHITECTURES.get(arch) if isinstance(arch, str) else None
    if model is None:
        raise ConfigError(f"{where}: key 'architecture': unknown architecture {arch!r} "
                          f"(known: {', '.join(ARCHITECTURES)})")
    foreign = _foreign_key(data, arch, model)
    if foreign and "architecture" not in data:
        fits = [a for a, m in ARCHITECTURES.items() if set(data) <= set(m.model_fields)]
        hint = f"add 'architecture: {fits[0]}'" if fits else \
            f"add 'architecture:' (one of {', '.join(ARCHITECTURES)})"
        raise ConfigError(f"{where}: key 'architecture' is missing, so the file is read as a "
                          f"power_split vehicle, but its blocks are another's: {hint}")
    if foreign:
        raise ConfigError(f"{where}: mixed architectures: {foreign}")
    try:
        veh = model.model_validate(copy.deepcopy(data))
    except ValidationError as exc:
        raise ConfigError(f"{where}: invalid vehicle: {validation_text(exc)}") from None
    return veh


def _find(text: str, here: Path | None = None) -> Path:
    """The file of a vehicle name or path (a relative path first beside ``here``)."""
    path = Path(text)
    if here is not None and not path.is_absolute() and (here / path).exists():
        return here / path
    if not (path.suffix in (".yaml", ".yml") or path.exists()):
        path = _vehicles_dir() / f"{text}.yaml"
        if not path.exists():
            known = list_vehicles()
            near = [n for n in known if n.rsplit("/", 1)[-1] == text]
            hint = f" (did you mean {near[0]}?)" if near else ""
            raise ConfigError(f"unknown vehicle '{text}'{hint}: known vehicles are "
                              f"{', '.join(known)}, or give a path to a YAML file")
    return path


def _read_base(name: str, here: Path) -> tuple[Any, str]:
    path = _find(name, here)
    return read_yaml(path), str(path)


def load_vehicle(name_or_path: str | Path | Vehicle | ConventionalVehicle
                 | ParallelHybridVehicle | BatteryElectricVehicle):
    """Load a vehicle by name (shipped file) or from a YAML path.

    Raises
    ------
    ConfigError
        Unknown name, unreadable file, or any invalid / missing / unknown key (the message
        names the key and the file).
    """
    if isinstance(name_or_path, (Vehicle, ConventionalVehicle, ParallelHybridVehicle,
                                BatteryElectricVehicle)):
        return name_or_path
    path = _find(str(name_or_path))
    data = read_yaml(path)
    if isinstance(data, dict) and data.get("variant_of") is not None:
        data = resolve_variant(data, str(path), lambda n: _read_base(n, path.parent))
    veh = _validate(data, str(path))
    veh._file = str(path)
    return veh
