"""Parameter blocks of the supervisory controller and of the driver model (vehicle file).

The state machine and the driver that use them are in :mod:`vehval.sim.control` and
:mod:`vehval.sim.driver`.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from vehval.vehicle.base import Block


class ControllerParams(Block):
    """All thresholds of the supervisory controller (SI units, unit in the key name)."""

    soc_target: float = Field(gt=0, lt=1)
    soc_gain_w: float = Field(ge=0)
    soc_charge_power_max_w: float = Field(ge=0)
    soc_discharge_power_max_w: float = Field(ge=0)
    engine_on_power_w: float
    engine_on_power_hold_s: float = Field(ge=0)
    engine_off_power_w: float
    engine_on_speed_mps: float = Field(gt=0)
    engine_on_speed_hold_s: float = Field(ge=0)
    engine_off_speed_mps: float = Field(gt=0)
    battery_condition_hold_s: float = Field(ge=0)
    electric_drive_efficiency: float = Field(gt=0, le=1)
    engine_off_hold_s: float = Field(ge=0)
    soc_engine_on: float = Field(gt=0, lt=1)
    soc_engine_on_hold_s: float = Field(ge=0)
    soc_force_on: float = Field(gt=0, lt=1)
    min_on_time_s: float = Field(ge=0)
    min_off_time_s: float = Field(ge=0)
    battery_discharge_margin_w: float = Field(ge=0)
    battery_charge_margin_w: float = Field(ge=0)
    engine_min_power_w: float = Field(ge=0)
    engine_power_filter_s: float = Field(ge=0)
    fuel_cut_power_w: float = Field(ge=0)
    fuel_cut_min_speed_mps: float = Field(ge=0)
    regen_fraction_max: float = Field(ge=0, le=1)
    regen_fade_low_mps: float = Field(ge=0)
    regen_fade_high_mps: float = Field(gt=0)
    gen_speed_kp_nm_per_radps: float = Field(gt=0)
    gen_speed_ki_nm_per_rad: float = Field(ge=0)
    gen_speed_margin_rpm: float = Field(ge=0)
    engine_speed_margin_rpm: float = Field(ge=0)
    soc_correction_path_efficiency: float = Field(gt=0, le=1)
    cold_start_engine_on_s: float = Field(default=0.0, ge=0, le=3600)
    """A cold-start run holds the engine on for this long from its start [s] (catalyst
    heating, warm-up); the controller sets its power as usual. 0: no hold."""
    cold_start_engine_power_w: float = Field(default=0.0, ge=0, le=1e6)
    """During the cold-start hold the engine delivers at least this power [W], the surplus
    over the drive demand charging the battery within its limits (a warming engine runs
    loaded). 0: the controller's power, idling when it asks for none; else at least
    ``engine_min_power_w``."""
    operating_point: Literal["system", "best_line"] = "best_line"
    """Engine speed choice while the engine delivers power: ``best_line`` places the power on
    the engine's own best-efficiency line; ``system`` picks the speed of least fuel plus the
    fuel-equivalent of the electrical path (MG1, MG2, boost, battery) at each step."""

    @model_validator(mode="after")
    def _consistent(self):
        if self.engine_off_speed_mps > self.engine_on_speed_mps:
            raise ValueError("'engine_off_speed_mps' must not exceed 'engine_on_speed_mps' "
                             "(the hysteresis would make the engine oscillate)")
        if self.engine_off_power_w > self.engine_on_power_w:
            raise ValueError("'engine_off_power_w' must not exceed 'engine_on_power_w'")
        if self.soc_force_on > self.soc_engine_on:
            raise ValueError("'soc_force_on' must not exceed 'soc_engine_on'")
        if self.regen_fade_low_mps >= self.regen_fade_high_mps:
            raise ValueError("'regen_fade_low_mps' must be below 'regen_fade_high_mps'")
        if 0.0 < self.cold_start_engine_power_w < self.engine_min_power_w:
            raise ValueError(
                f"'cold_start_engine_power_w' {self.cold_start_engine_power_w:g} W is below "
                f"'engine_min_power_w' {self.engine_min_power_w:g} W, the least power the "
                "engine delivers when loaded: give 0 (no floor) or at least that")
        return self


class DriverParams(Block):
    """Speed-follower gains and force bounds."""

    response_time_s: float = Field(gt=0)
    ki_n_per_m: float = Field(ge=0)
    integrator_limit_n: float = Field(ge=0)
    max_force_n: float = Field(gt=0)
    tolerance_speed_mph: float = Field(gt=0)
    tolerance_time_s: float = Field(ge=0)
