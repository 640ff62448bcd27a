"""NiMH battery pack: open-circuit voltage and internal resistance over SOC, power limits."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from pydantic import Field, model_validator

from vehval.sim.components.base import Block, bp_check, table_check


class BatteryParams(Block):
    """Pack-level battery parameters (voltages and resistances of the whole pack)."""

    soc: list[float]
    ocv_v: list[float]
    resistance_discharge_ohm: list[float]
    resistance_charge_ohm: list[float]
    discharge_power_limit_w: list[float]
    charge_power_limit_w: list[float]
    capacity_ah: float = Field(gt=0)
    n_cells: int = Field(gt=0)
    n_modules: int = Field(gt=0)
    nominal_voltage_v: float = Field(gt=0)
    soc_min: float = Field(ge=0, le=1)
    soc_max: float = Field(ge=0, le=1)

    @model_validator(mode="after")
    def _maps(self):
        bp_check(self.soc, "soc")
        n = len(self.soc)
        for key in ("ocv_v", "resistance_discharge_ohm", "resistance_charge_ohm",
                    "discharge_power_limit_w", "charge_power_limit_w"):
            table_check(getattr(self, key), n, None, key)
            if np.any(np.asarray(getattr(self, key)) < 0):
                raise ValueError(f"'{key}' must not be negative")
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


@njit(cache=True)
def current_from_power(power, ocv, resistance):
    """Terminal current [A] (positive discharging) delivering ``power`` [W] at the terminals.

    Solves ``P = (V_oc - I R) I`` for the smaller root. Beyond the maximum power
    ``V_oc^2 / (4 R)`` the current at maximum power is returned.
    """
    disc = ocv * ocv - 4.0 * resistance * power
    if disc < 0.0:
        return ocv / (2.0 * resistance)
    return (ocv - math.sqrt(disc)) / (2.0 * resistance)


@njit(cache=True)
def terminal_voltage(ocv, resistance, current):
    """Terminal voltage [V] = V_oc - I·R."""
    return ocv - current * resistance
