"""Conventional powertrain: engine -> torque converter -> automatic gearbox -> final drive.

Parameter blocks of a vehicle file with ``architecture: conventional``. The engine block is
the same :class:`~vehval.vehicle.components.EngineParams` as the hybrid's (fuel map, full-load
curve, idle, inertia, fuel); the blocks here add what a conventional car needs:

- ``engine_control``: idle fuel rate at standstill, fuel cut on overrun (minimum engine
  speed, residual fuel rate), engine-driven accessory power, the A/C compressor's load and
  whether the A/C runs (a test condition: ``vehval predict`` sets it per test).
- ``gearbox``: gear ratios (gearbox only; the final drive is in ``driveline``), efficiency,
  driveline drag at the wheels ``A_d + B_d v`` (driven-axle losses, e.g. the tyres on the
  rollers, that a dyno's set coefficients leave out of the measured force),
  shift schedule as straight up/down lines of vehicle speed against load (load = demanded
  power / engine maximum power, 0..1), minimum time between shifts.
- ``converter``: a fluid coupling with lock-up, documented in docs/simulation.md: torque
  ratio 1, pump torque ``T = k · ω_p · (ω_p − ω_t)`` (k = capacity, linearised coupling
  law), locked in a gear above that gear's lock-up vehicle speed.

The physics is in :mod:`vehval.sim.conventional_kernel`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.vehicle.base import Block, BlockVehicle
from vehval.vehicle.components import BodyParams, DrivelineParams, EngineParams
from vehval.vehicle.control import DriverParams

#: Share of a car's own losses on the dyno rollers (target - set coefficients) that its
#: driven axle carries, i.e. that load the engine: two of the four tyres plus the
#: differential (an engineering estimate; dyno fuel data cannot separate it).
DRIVEN_AXLE_LOSS_SHARE = 0.5

CONVENTIONAL_BLOCKS = ("body", "engine", "engine_control", "gearbox", "converter", "driveline",
                       "driver")


class EngineControlParams(Block):
    """Idle, fuel cut on overrun and the engine-driven accessory load."""

    idle_fuel_rate_g_per_s: float = Field(ge=0)
    fuel_cut_min_speed_rpm: float = Field(ge=0)
    overrun_fuel_rate_g_per_s: float = Field(ge=0)
    accessory_power_w: float = Field(ge=0)
    ac_power_w: float = Field(default=0.0, ge=0)  # [W] A/C compressor shaft power when on
    ac_on: bool = False


class GearboxParams(Block):
    """Automatic gearbox: ratios (first gear first) and the shift schedule.

    Shift line of gear i -> i+1 (up) or i+1 -> i (down): vehicle speed [m/s] at zero load
    and at full load, straight in between. Lists have one entry per gear pair.
    """

    ratios: list[float]
    efficiency: float = Field(gt=0, le=1)
    upshift_speed_mps: list[float]
    upshift_speed_full_load_mps: list[float]
    downshift_speed_mps: list[float]
    downshift_speed_full_load_mps: list[float]
    shift_time_s: float = Field(ge=0)
    drag_force_n: float = Field(default=0.0, ge=0)  # [N] driveline drag at the wheels
    drag_force_n_per_mps: float = Field(default=0.0, ge=0)  # [N/(m/s)]

    @model_validator(mode="after")
    def _schedule(self):
        r = np.asarray(self.ratios, float)
        if r.ndim != 1 or r.size < 1 or np.any(r <= 0):
            raise ValueError("'ratios' must be a list of positive numbers (first gear first)")
        if np.any(np.diff(r) >= 0):
            raise ValueError("'ratios' must decrease from first gear to top gear")
        n = r.size - 1
        for key in ("upshift_speed_mps", "upshift_speed_full_load_mps", "downshift_speed_mps",
                    "downshift_speed_full_load_mps"):
            vals = getattr(self, key)
            if len(vals) != n:
                raise ValueError(f"'{key}' needs {n} entries (one per gear pair), got {len(vals)}")
            if any(x < 0 for x in vals):
                raise ValueError(f"'{key}' must not be negative")
        for i in range(n):
            if self.downshift_speed_mps[i] >= self.upshift_speed_mps[i] or \
                    self.downshift_speed_full_load_mps[i] >= self.upshift_speed_full_load_mps[i]:
                raise ValueError(f"gear pair {i + 1}-{i + 2}: the downshift line must lie below "
                                 "the upshift line (hysteresis), or the gearbox would hunt")
        return self


class ConverterParams(Block):
    """Torque converter as a lock-up fluid coupling (see the module docstring)."""

    capacity_nm_s2_per_rad2: float = Field(gt=0)
    lockup_speed_mps: list[float]

    @model_validator(mode="after")
    def _positive(self):
        if any(x < 0 for x in self.lockup_speed_mps):
            raise ValueError("'lockup_speed_mps' must not be negative")
        return self


class ConventionalVehicle(BlockVehicle):
    """A conventional car: engine, torque converter, automatic gearbox, final drive."""

    model_config = ConfigDict(extra="forbid")

    architecture: Literal["conventional"]
    name: str
    description: str = ""
    body: BodyParams
    engine: EngineParams
    engine_control: EngineControlParams
    gearbox: GearboxParams
    converter: ConverterParams
    driveline: DrivelineParams
    driver: DriverParams
    identification: dict = Field(default_factory=dict)

    def _blocks(self) -> tuple[str, ...]:
        return CONVENTIONAL_BLOCKS

    @model_validator(mode="after")
    def _consistent(self):
        n = len(self.gearbox.ratios)
        if len(self.converter.lockup_speed_mps) != n:
            raise ValueError(f"'converter.lockup_speed_mps' needs one entry per gear ({n})")
        return self

    def overall_ratios(self) -> np.ndarray:
        """Engine-to-wheel speed ratio of every gear [-] (gearbox x final drive)."""
        return np.asarray(self.gearbox.ratios, float) * self.driveline.final_drive_ratio

    def signal_limits(self) -> dict[str, tuple[float, float]]:
        """Physical limits per signal base name, SI units (for QA range checks)."""
        e, d = self.engine, self.driveline
        w_max = e.max_speed_rpm * RPM
        v_max = w_max * d.wheel_radius_m / float(self.overall_ratios()[-1])
        tmax = float(np.max(e.max_torque_nm))
        return {
            "veh_spd": (0.0, v_max),
            "whl_spd": (0.0, v_max / d.wheel_radius_m),
            "eng_spd_out": (0.0, w_max),
            "eng_trq_out": (-e.motoring_torque_nm, tmax),
            "eng_pwr_out": (-e.motoring_torque_nm * w_max, e.max_power_w),
            "fuel_rate": (0.0, float(np.max(e.fuel_rate_g_per_s)) * 1e-3),
        }
