"""Parameter blocks of the powertrain components, as read from a vehicle file.

Each block is a pydantic model that rejects unknown keys and requires a source for every
parameter (:class:`~vehval.vehicle.base.Block`). Units are in the key names; maps are
plain nested lists, converted to SI arrays by ``arrays()``. Scalar parameters carry
plausibility bounds (a mass of 1e308 kg or a wheel radius of 1 km is refused with its key),
wide enough for any road vehicle on a chassis dyno. The simulator, QA, analysis and
the report all read these blocks; the physics that uses them lives in :mod:`vehval.sim`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.vehicle.base import Block, bp_check, check_speed_axis, table_check


class BodyParams(Block):
    """Test mass, dyno road-load coefficients and the electrical accessory load.

    ``road_load_a_n`` may be negative: dyno *set* coefficients (the car's own losses on the
    rollers taken out of the target) often are.
    """

    mass_kg: float = Field(ge=50, le=60_000)  # plausible: a 50 kg kart to a 60 t truck
    road_load_a_n: float = Field(ge=-2_000, le=20_000)
    road_load_b_n_per_mps: float = Field(ge=0, le=2_000)
    road_load_c_n_per_mps2: float = Field(ge=0, le=200)
    aux_power_w: float = Field(ge=0, le=200_000)


class EngineParams(Block):
    """Engine parameters. Speeds in rpm in the file, converted to rad/s by :meth:`arrays`."""

    speed_rpm: list[float]
    torque_nm: list[float]
    fuel_rate_g_per_s: list[list[float]]
    max_torque_nm: list[float]
    max_power_w: float = Field(gt=0, le=5e6)
    max_speed_rpm: float = Field(gt=0, le=30_000)
    idle_speed_rpm: float = Field(gt=0, le=30_000)
    fire_speed_rpm: float = Field(gt=0, le=30_000)
    motoring_torque_nm: float = Field(ge=0, le=1e5)
    inertia_kg_m2: float = Field(gt=0, le=1e3)
    fuel: str | None = None
    """The fuel, a name of the fuel table (``gasoline_e0``); it gives the two values below
    (with their sources) unless the file gives them explicitly."""
    fuel_density_kg_per_m3: float = Field(gt=0, le=2_000)
    fuel_lhv_j_per_kg: float = Field(ge=5e6, le=1.5e8)  # methanol to hydrogen
    displacement_l: float | None = Field(default=None, gt=0, le=20)
    """Swept volume [L]; informative (scaling, reports), not used by the simulation."""
    warmup_fuel_fraction: float = Field(default=0.0, ge=0, le=5)
    """Extra fuel [-] of a cold-started engine at the start of the run (the fuel rate of a
    cold-start run is x (1 + fraction exp(-t / warmup_time_constant_s))); 0: no warm-up."""
    warmup_time_constant_s: float = Field(default=300.0, gt=0, le=1e4)
    """Decay time constant [s] of the warm-up extra fuel over the run time."""

    @model_validator(mode="before")
    @classmethod
    def _fuel_from_table(cls, data):
        """Fill the fuel density and LHV of a named ``fuel`` from the fuel table."""
        if not isinstance(data, dict) or not data.get("fuel"):
            return data
        from vehval.errors import ConfigError
        from vehval.fuels import table_fuel

        try:
            fuel = table_fuel(str(data["fuel"]))
        except ConfigError as exc:
            raise ValueError(str(exc).removeprefix("fuel: ")) from None
        data = dict(data)
        sources = dict(data.get("sources") or {})
        for key, prop in (("fuel_density_kg_per_m3", "density_kg_per_m3"),
                          ("fuel_lhv_j_per_kg", "lhv_j_per_kg")):
            if data.get(key) is None:
                data[key] = getattr(fuel, prop)
                sources[key] = f"fuel table {fuel.name}: {fuel.sources[prop]}"
        data["sources"] = sources
        return data

    @model_validator(mode="after")
    def _maps(self):
        bp_check(self.speed_rpm, "speed_rpm")
        bp_check(self.torque_nm, "torque_nm")
        table_check(self.fuel_rate_g_per_s, len(self.speed_rpm), len(self.torque_nm),
                    "fuel_rate_g_per_s")
        table_check(self.max_torque_nm, len(self.speed_rpm), None, "max_torque_nm")
        if np.any(np.asarray(self.fuel_rate_g_per_s) < 0):
            raise ValueError("'fuel_rate_g_per_s' must not be negative")
        tmax = np.asarray(self.max_torque_nm, float)
        if np.any(tmax < 0) or not np.any(tmax > 0):
            raise ValueError(f"'max_torque_nm' (full-load torque) must not be negative and must "
                             f"be positive somewhere (got {min(self.max_torque_nm):g} to "
                             f"{max(self.max_torque_nm):g} N·m)")
        if not self.idle_speed_rpm < self.max_speed_rpm:
            raise ValueError("'idle_speed_rpm' must be below 'max_speed_rpm'")
        if not self.fire_speed_rpm < self.max_speed_rpm:
            raise ValueError(f"'fire_speed_rpm' = {self.fire_speed_rpm:g} must be below "
                             f"'max_speed_rpm' = {self.max_speed_rpm:g} (the engine could never fire)")
        check_speed_axis(self.speed_rpm, self.max_speed_rpm)
        return self

    def arrays(self) -> dict[str, np.ndarray]:
        """Maps in SI: speed [rad/s], torque [N·m], fuel rate [kg/s], max torque [N·m]."""
        return {
            "spd": np.asarray(self.speed_rpm, float) * RPM,
            "trq": np.asarray(self.torque_nm, float),
            "fuel": np.asarray(self.fuel_rate_g_per_s, float) * 1e-3,
            "tmax": np.asarray(self.max_torque_nm, float),
        }


class MachineParams(Block):
    """Electric machine parameters (loss map over speed x torque, limits, inertia)."""

    speed_rpm: list[float]
    torque_nm: list[float]
    loss_w: list[list[float]]
    max_torque_nm: float = Field(gt=0, le=1e5)
    max_power_w: float = Field(gt=0, le=5e6)
    max_speed_rpm: float = Field(gt=0, le=50_000)
    inertia_kg_m2: float = Field(gt=0, le=1e3)

    @model_validator(mode="after")
    def _maps(self):
        bp_check(self.speed_rpm, "speed_rpm")
        bp_check(self.torque_nm, "torque_nm")
        table_check(self.loss_w, len(self.speed_rpm), len(self.torque_nm), "loss_w")
        if np.any(np.asarray(self.loss_w) < 0):
            raise ValueError("'loss_w' must not be negative (losses are always >= 0)")
        check_speed_axis(self.speed_rpm, self.max_speed_rpm)
        return self

    def arrays(self) -> dict[str, np.ndarray]:
        """Loss map in SI: speed [rad/s], torque [N·m], loss [W]."""
        return {"spd": np.asarray(self.speed_rpm, float) * RPM,
                "trq": np.asarray(self.torque_nm, float),
                "loss": np.asarray(self.loss_w, float)}


class BatteryParams(Block):
    """Pack-level battery parameters (voltages and resistances of the whole pack)."""

    soc: list[float]
    ocv_v: list[float]
    resistance_discharge_ohm: list[float]
    resistance_charge_ohm: list[float]
    discharge_power_limit_w: list[float]
    charge_power_limit_w: list[float]
    capacity_ah: float = Field(gt=0, le=1e4)
    n_cells: int = Field(gt=0, le=100_000)
    n_modules: int = Field(gt=0, le=100_000)
    nominal_voltage_v: float = Field(gt=0, le=2_000)
    soc_min: float = Field(ge=0, le=1)
    soc_max: float = Field(ge=0, le=1)
    chemistry: Literal["nimh", "li_ion"] = "nimh"
    """Cell chemistry: ``nimh`` (nickel-metal hydride, the 2004 pack) or ``li_ion``; the
    pack's behaviour is in its OCV, resistance and power-limit tables."""

    @model_validator(mode="after")
    def _maps(self):
        bp_check(self.soc, "soc")
        if self.soc[0] < 0 or self.soc[-1] > 1:
            raise ValueError(f"'soc' breakpoints must lie in [0, 1] (a fraction, not percent; "
                             f"got {self.soc[0]:g} to {self.soc[-1]:g})")
        n = len(self.soc)
        for key in ("ocv_v", "resistance_discharge_ohm", "resistance_charge_ohm",
                    "discharge_power_limit_w", "charge_power_limit_w"):
            table_check(getattr(self, key), n, None, key)
            if np.any(np.asarray(getattr(self, key)) < 0):
                raise ValueError(f"'{key}' must not be negative")
        if np.any(np.asarray(self.ocv_v) <= 0):
            raise ValueError("'ocv_v' (open-circuit voltage) must be positive at every SOC")
        if np.any(np.asarray(self.resistance_discharge_ohm) <= 0) or \
                np.any(np.asarray(self.resistance_charge_ohm) <= 0):
            raise ValueError("battery resistances must be positive")
        if not self.soc_min < self.soc_max:
            raise ValueError("'soc_min' must be below 'soc_max'")
        if self.n_cells % self.n_modules:
            raise ValueError("'n_cells' must be a multiple of 'n_modules'")
        return self

    @property
    def capacity_c(self) -> float:
        """Charge capacity [C]."""
        return self.capacity_ah * 3600.0


class BoostParams(Block):
    """Constant-efficiency boost converter with a speed-scheduled output voltage."""

    efficiency: float = Field(gt=0, le=1)
    volt_out_max_v: float = Field(gt=0, le=3_000)
    volt_out_min_v: float = Field(gt=0, le=3_000)
    volt_full_speed_rpm: float = Field(gt=0, le=50_000)

    @model_validator(mode="after")
    def _range(self):
        if self.volt_out_min_v > self.volt_out_max_v:
            raise ValueError("'volt_out_min_v' must not exceed 'volt_out_max_v'")
        return self


class PlanetaryParams(Block):
    """Tooth numbers and the inertias of carrier and ring."""

    sun_teeth: int = Field(gt=0, le=1_000)
    ring_teeth: int = Field(gt=0, le=1_000)
    carrier_inertia_kg_m2: float = Field(ge=0, le=1e3)
    ring_inertia_kg_m2: float = Field(ge=0, le=1e3)

    @model_validator(mode="after")
    def _ring_around_sun(self):
        if self.ring_teeth <= self.sun_teeth:
            raise ValueError(f"'ring_teeth' = {self.ring_teeth} must exceed 'sun_teeth' = "
                             f"{self.sun_teeth} (the ring gear surrounds the sun)")
        return self


class DrivelineParams(Block):
    """Final drive, wheel and brake parameters."""

    final_drive_ratio: float = Field(ge=0.5, le=50)
    final_drive_efficiency: float = Field(gt=0, le=1)
    wheel_radius_m: float = Field(ge=0.1, le=2.0)
    wheel_inertia_kg_m2: float = Field(ge=0, le=1e3)
    brake_max_force_n: float = Field(gt=0, le=1e6)
    mg2_reduction_ratio: float = Field(default=1.0, gt=0, le=20)
    """MG2 shaft speed / ring gear speed [-]: 1 when MG2 sits on the ring (2004 THS II), the
    motor reduction gear ratio in later power-split cars (about 2.6 in the 2010 Prius)."""
