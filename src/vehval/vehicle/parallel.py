"""Parallel hybrid: engine and motor on one shaft ahead of the gearbox (Honda IMA).

Parameter blocks of a vehicle file with ``architecture: parallel_hybrid``. The engine is the
same :class:`~vehval.vehicle.components.EngineParams` as every other car's; the motor and the
battery are the power-split's :class:`~vehval.vehicle.components.MachineParams` and
:class:`~vehval.vehicle.components.BatteryParams`; the gearbox (ratios, shift lines) is the
conventional car's :class:`~vehval.vehicle.conventional.GearboxParams`. A ``converter`` block
makes the gearbox an automatic (the conventional car's lock-up coupling); without it the
gearbox is a manual with a slipping launch clutch.

The strategy block ``controller`` (:class:`ParallelControlParams`) holds the named thresholds
of the assist / regen / idle-stop rules, all in the units of their key names:

- assist: the motor adds torque when the shaft torque demand passes
  ``assist_threshold_nm``, in gear ``assist_min_gear`` or above, with SOC above
  ``assist_soc_min``: ``assist_min_nm + assist_slope * (demand - threshold)``, at most
  ``assist_max_nm``;
- regen: below ``regen_threshold_nm`` of shaft torque, above ``regen_min_speed_mps`` and
  SOC below ``regen_soc_max``, the motor takes ``regen_fraction`` of the braking torque;
- charge: cruising below ``soc_target - charge_soc_band`` the motor loads the engine with
  ``charge_torque_nm``;
- idle stop: the engine stops when the car decelerates below ``engine_stop_speed_mps``
  or stands, once SOC is above ``engine_stop_soc_min``; it restarts when the driver asks
  for drive torque (the motor cranks it: ``restart_energy_j`` from the battery).

The physics is in :mod:`vehval.sim.parallel_kernel`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.vehicle.base import Block, BlockVehicle, check_soc_target
from vehval.vehicle.components import BatteryParams, BodyParams, DrivelineParams, EngineParams, MachineParams
from vehval.vehicle.control import DriverParams
from vehval.vehicle.conventional import ConverterParams, GearboxParams

PARALLEL_BLOCKS = ("body", "engine", "motor", "battery", "gearbox", "driveline", "controller",
                   "driver")


class ParallelControlParams(Block):
    """Named thresholds of the assist / regen / charge / idle-stop strategy (module doc)."""

    soc_target: float = Field(gt=0, lt=1)
    assist_threshold_nm: float = Field(ge=0)
    assist_min_nm: float = Field(ge=0)
    assist_slope: float = Field(ge=0)
    assist_max_nm: float = Field(ge=0)
    assist_min_gear: int = Field(ge=1, le=12)
    assist_soc_min: float = Field(ge=0, lt=1)
    regen_threshold_nm: float = Field(le=0)
    regen_fraction: float = Field(ge=0, le=1)
    regen_min_speed_mps: float = Field(ge=0)
    regen_soc_max: float = Field(gt=0, le=1)
    charge_torque_nm: float = Field(ge=0)
    charge_soc_band: float = Field(ge=0, lt=1)
    engine_stop_speed_mps: float = Field(ge=0)
    engine_stop_soc_min: float = Field(ge=0, lt=1)
    restart_energy_j: float = Field(ge=0, le=1e5)
    soc_correction_path_efficiency: float = Field(default=0.85, gt=0, le=1)
    """Engine-to-battery path efficiency [-] of the simulator's energy-balance SOC
    correction (motor generating, battery charge)."""
    fuel_cut_min_speed_rpm: float = Field(ge=0, le=30_000)
    """Overrun (engine torque <= 0) above this shaft speed cuts the fuel [rpm]."""
    electrical_aux_power_w: float = Field(ge=0, le=1e5)
    """Accessory load on the high-voltage battery [W] (the 12 V DC/DC); ``body.aux_power_w``
    is the mechanical load on the engine shaft."""
    motor_off_when_idle: bool = False
    """The inverter draws nothing while the strategy commands no motor torque (the
    machine's zero-torque loss then comes from the shaft as drag, within the engine's
    friction); False (ADVISOR's maps): the motor's loss map at zero torque is drawn from the
    battery whenever the engine turns."""

    @model_validator(mode="after")
    def _consistent(self):
        if self.assist_min_nm > self.assist_max_nm:
            raise ValueError("'assist_min_nm' must not exceed 'assist_max_nm'")
        if self.assist_soc_min >= self.regen_soc_max:
            raise ValueError("'assist_soc_min' must be below 'regen_soc_max'")
        return self


class ParallelHybridVehicle(BlockVehicle):
    """A parallel hybrid: engine + motor on the crankshaft, gearbox, final drive, battery."""

    model_config = ConfigDict(extra="forbid")

    architecture: Literal["parallel_hybrid"]
    name: str
    description: str = ""
    body: BodyParams
    engine: EngineParams
    motor: MachineParams
    battery: BatteryParams
    gearbox: GearboxParams
    converter: ConverterParams | None = None
    driveline: DrivelineParams
    controller: ParallelControlParams
    driver: DriverParams
    transmission: Literal["manual", "automatic"] = "manual"
    identification: dict = Field(default_factory=dict)

    @model_validator(mode="after")
    def _consistent(self):
        n = len(self.gearbox.ratios)
        if self.transmission == "automatic":
            if self.converter is None:
                raise ValueError("an automatic transmission needs a 'converter' block")
            if len(self.converter.lockup_speed_mps) != n:
                raise ValueError(f"'converter.lockup_speed_mps' needs one entry per gear ({n})")
        elif self.converter is not None:
            raise ValueError("'converter' belongs to transmission: automatic (this is manual)")
        if self.controller.assist_min_gear > n:
            raise ValueError(f"'controller.assist_min_gear' exceeds the {n} gears")
        check_soc_target(self.controller.soc_target, self.battery)
        return self

    def _blocks(self) -> tuple[str, ...]:
        return PARALLEL_BLOCKS + (("converter",) if self.converter is not None else ())

    def overall_ratios(self) -> np.ndarray:
        """Shaft-to-wheel speed ratio of every gear [-] (gearbox x final drive)."""
        return np.asarray(self.gearbox.ratios, float) * self.driveline.final_drive_ratio

    def signal_limits(self) -> dict[str, tuple[float, float]]:
        """Physical limits per signal base name, SI units (for QA range checks)."""
        e, m, b, d = self.engine, self.motor, self.battery, self.driveline
        w_max = e.max_speed_rpm * RPM
        v_max = w_max * d.wheel_radius_m / float(self.overall_ratios()[-1])
        tmax = float(np.max(e.max_torque_nm))
        return {
            "veh_spd": (0.0, v_max),
            "whl_spd": (0.0, v_max / d.wheel_radius_m),
            "eng_spd_out": (0.0, w_max),
            "eng_trq_out": (-e.motoring_torque_nm, tmax),
            "eng_pwr_out": (-e.motoring_torque_nm * w_max, e.max_power_w),
            "mot_spd_out": (0.0, m.max_speed_rpm * RPM),
            "mot_trq_out": (-m.max_torque_nm, m.max_torque_nm),
            "mot_pwr_out": (-m.max_power_w, m.max_power_w),
            "ess_soc": (b.soc_min, b.soc_max),
            "ess_pwr": (-float(np.max(b.charge_power_limit_w)),
                        float(np.max(b.discharge_power_limit_w))),
            "ess_volt": (0.0, float(np.max(b.ocv_v)) * 1.3),
            "fuel_rate": (0.0, float(np.max(e.fuel_rate_g_per_s)) * 1e-3),
        }
