"""Battery-electric vehicle: battery -> inverter + motor -> single reduction -> wheels.

Parameter blocks of a vehicle file with ``architecture: battery_electric``:

- ``body``: test mass, road load, the electrical accessory load ``aux_power_w`` (DC bus).
- ``battery``: the hybrid's pack block (:class:`~vehval.vehicle.components.BatteryParams`):
  OCV and internal resistance over SOC, capacity, SOC window and power limits over SOC.
- ``motor``: motor with its inverter (:class:`~vehval.vehicle.components.MachineParams`):
  loss map over speed and torque (DC power minus shaft power, all four quadrants), peak
  torque, peak power, maximum speed, rotor inertia. :func:`generic_motor_block` scales the
  measured 2004 Prius MG2 + inverter loss surface (ORNL) to another rating.
- ``driveline``: the single reduction (``final_drive_ratio``: motor speed / wheel speed,
  ``final_drive_efficiency``), wheel radius and inertia, friction-brake limit.
- ``regen``: regenerative braking: electric braking power limit at the wheels, the fade
  below a speed (none below ``fade_low_mps``, full above ``fade_high_mps``), the share of
  the braking force the driven axle carries (the rest is friction on the other axle).
- ``charger``: charger efficiency wall -> battery (AC energy of SAE J1634 results), and the
  SOC the test starts from.
- ``driver``: the speed follower.

The physics is in :mod:`vehval.sim.bev_kernel`.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from vehval.constants import RPM_RAD_PER_S as RPM
from vehval.integrals import integral
from vehval.vehicle.base import Block, BlockVehicle
from vehval.vehicle.components import BatteryParams, BodyParams, DrivelineParams, MachineParams
from vehval.vehicle.control import DriverParams
from vehval.vehicle.machine_fit import LossSurface, loss_table, scaled_losses

BEV_BLOCKS = ("body", "battery", "motor", "driveline", "regen", "charger", "driver")

#: The 2004 Prius MG2 + inverter loss surface fitted to ORNL/TM-2006/423 Table B-1
#: (coefficients in :data:`vehval.vehicle.machine_fit.TERMS` order, w rad/s, T N·m; the
#: fit of the shipped prius_2004 vehicle file) and the rating it was measured at.
PRIUS_MG2_SURFACE = LossSurface(coef=(177.3, 0.0, 0.008482, 4.423, 0.06255, 8.401e-07))
PRIUS_MG2_MAX_SPEED_RPM = 6500.0
PRIUS_MG2_MAX_POWER_W = 50_000.0
PRIUS_MG2_SOURCE = (
    "ORNL/TM-2006/423 Table B-1 (2004 Prius MG2 + inverter, DC power minus shaft power), "
    "fitted loss surface L = c0 + c1|w| + c2 w^2 + c3|T| + c4 T^2 + c5 (T w)^2 "
    "(vehval.vehicle.machine_fit; c0 177.3 W, c2 0.008482 W/(rad/s)^2, c3 4.423 W/(N·m), "
    "c4 0.06255 W/(N·m)^2, c5 8.401e-07 W/W^2; 50 kW, 6500 rpm), scaled as ADVISOR and "
    "Autonomie scale machines (speeds x max speed ratio, losses x power ratio); generating "
    "= mirror of motoring")


class RegenParams(Block):
    """Regenerative braking limits."""

    max_power_w: float = Field(gt=0, le=2e6)  # [W] electric braking power at the wheels
    fade_low_mps: float = Field(ge=0, le=30)  # [m/s] no regeneration below
    fade_high_mps: float = Field(ge=0, le=40)  # [m/s] full regeneration above
    driven_axle_share: float = Field(gt=0, le=1)  # [-] braking force on the driven axle

    @model_validator(mode="after")
    def _fade(self):
        if self.fade_high_mps < self.fade_low_mps:
            raise ValueError("'fade_high_mps' must not be below 'fade_low_mps'")
        return self


class ChargerParams(Block):
    """On-board charger and the test's starting SOC."""

    efficiency: float = Field(gt=0, le=1)  # [-] wall (AC) -> battery (DC)
    soc_initial: float = Field(ge=0, le=1)  # [-] SOC at the start of a run


class BatteryElectricVehicle(BlockVehicle):
    """A battery-electric car: battery, motor with inverter, single reduction."""

    model_config = ConfigDict(extra="forbid")

    architecture: Literal["battery_electric"]
    name: str
    description: str = ""
    body: BodyParams
    battery: BatteryParams
    motor: MachineParams
    driveline: DrivelineParams
    regen: RegenParams
    charger: ChargerParams
    driver: DriverParams
    identification: dict = Field(default_factory=dict)

    def _blocks(self) -> tuple[str, ...]:
        return BEV_BLOCKS

    @model_validator(mode="after")
    def _consistent(self):
        b = self.battery
        if not b.soc_min <= self.charger.soc_initial <= b.soc_max:
            raise ValueError(f"'charger.soc_initial' = {self.charger.soc_initial:g} is outside "
                             f"the battery window [{b.soc_min:g}, {b.soc_max:g}]")
        if self.driveline.mg2_reduction_ratio != 1.0:
            raise ValueError("'driveline.mg2_reduction_ratio' is a power-split key: a "
                             "battery-electric car has one reduction, 'final_drive_ratio'")
        return self

    def usable_energy_j(self) -> float:
        """Energy [J] between ``soc_min`` and ``soc_max`` at the open-circuit voltage."""
        b = self.battery
        s = np.linspace(b.soc_min, b.soc_max, 201)
        ocv = np.interp(s, b.soc, b.ocv_v)
        return integral(s, ocv) * b.capacity_c

    def signal_limits(self) -> dict[str, tuple[float, float]]:
        """Physical limits per signal base name, SI units (for QA range checks)."""
        m, b, d = self.motor, self.battery, self.driveline
        w_max = m.max_speed_rpm * RPM
        v_max = w_max * d.wheel_radius_m / d.final_drive_ratio
        return {
            "veh_spd": (0.0, v_max),
            "whl_spd": (0.0, v_max / d.wheel_radius_m),
            "mot_spd_out": (-w_max, w_max),
            "mot_trq_out": (-m.max_torque_nm, m.max_torque_nm),
            "mot_pwr_out": (-m.max_power_w, m.max_power_w),
            "ess_soc": (0.0, 1.0),
            "ess_pwr": (-float(np.max(b.charge_power_limit_w)),
                        float(np.max(b.discharge_power_limit_w))),
            "ess_volt": (0.0, float(np.max(b.ocv_v)) * 1.3),
        }


def generic_motor_block(max_power_w: float, max_torque_nm: float, max_speed_rpm: float,
                        inertia_kg_m2: float, sources: dict[str, str],
                        loss_scale: float = 1.0, loss_scale_source: str = "",
                        n_speed: int = 21, n_torque: int = 41) -> dict:
    """A ``motor`` block (dict, vehicle-file form) with the generic loss map.

    The loss map is the 2004 Prius MG2 + inverter surface (:data:`PRIUS_MG2_SURFACE`)
    scaled to ``max_speed_rpm`` and ``max_power_w``, tabulated on a grid of ``n_speed``
    speeds (0..max) and ``n_torque`` torques (-max..max). ``sources`` gives the sources of
    the four ratings; the grid and map sources are added here. ``loss_scale`` multiplies
    the scaled losses (a newer machine and inverter than the 2004 one), its source
    ``loss_scale_source``.
    """
    spd = np.linspace(0.0, max_speed_rpm, n_speed)
    trq = np.linspace(-max_torque_nm, max_torque_nm, n_torque)
    s_w = max_speed_rpm / PRIUS_MG2_MAX_SPEED_RPM
    s_p = max_power_w / PRIUS_MG2_MAX_POWER_W
    loss = loss_table(lambda w, t: loss_scale * scaled_losses(PRIUS_MG2_SURFACE, w, t, s_w, s_p),
                      spd, trq)
    scale_text = "" if loss_scale == 1.0 else f"; losses x {loss_scale:.4g}: {loss_scale_source}"
    return {
        "speed_rpm": [round(float(x), 3) for x in spd],
        "torque_nm": [round(float(x), 3) for x in trq],
        "loss_w": loss, "max_torque_nm": float(max_torque_nm), "max_power_w": float(max_power_w),
        "max_speed_rpm": float(max_speed_rpm), "inertia_kg_m2": float(inertia_kg_m2),
        "sources": {**sources,
                    "speed_rpm": f"grid 0..max_speed_rpm, {n_speed} points",
                    "torque_nm": f"grid -max_torque_nm..max_torque_nm, {n_torque} points",
                    "loss_w": PRIUS_MG2_SOURCE + f" (speed x {s_w:.4g}, power x {s_p:.4g})"
                    + scale_text},
    }
