"""The engine on/off rule's parameters, without its compiled kernel.

:data:`RULE_KEYS` are the controller keys of the vehicle file that the rule
(:func:`vehval.sim.supervisor.engine_rule`) reads, :data:`RULE_INDEX` their positions in the
simulator's parameter vector (:data:`vehval.sim.layout.PARAMS`); :func:`rule_params` and
:func:`rule_vector` give a vehicle's values (or the reference rule's) as a dict or as that
vector. Importing this module loads no compiled code (no numba): the analysis of a
conventional car asks for the parameters and never replays the rule.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

from vehval.sim.layout import PARAMS
from vehval.sim.packing import FROM_FILE

#: controller keys of the vehicle file the rule reads
RULE_KEYS = (
    "engine_on_power_w", "engine_off_power_w", "engine_on_speed_mps", "engine_off_speed_mps",
    "min_on_time_s", "min_off_time_s", "engine_on_power_hold_s", "engine_on_speed_hold_s",
    "engine_off_hold_s", "battery_condition_hold_s", "soc_engine_on", "soc_engine_on_hold_s",
    "soc_force_on", "soc_target", "soc_gain_w", "soc_charge_power_max_w",
    "soc_discharge_power_max_w", "electric_drive_efficiency",
)
_LAYOUT_OF = {key: name for name, (blk, key, _f) in FROM_FILE.items() if blk == "controller"}
#: controller key -> position in the parameter vector
RULE_INDEX = {k: PARAMS.index(_LAYOUT_OF[k]) for k in RULE_KEYS}
#: the vehicle whose rule stands in when no vehicle is given (its SOC terms disabled: the
#: battery window of an unknown car is unknown)
REFERENCE_VEHICLE = "prius_2004"
_SOC_TERMS = ("soc_engine_on", "soc_force_on", "soc_gain_w", "soc_charge_power_max_w",
              "soc_discharge_power_max_w")


@lru_cache(maxsize=1)
def _reference_rule() -> tuple[tuple[str, float], ...]:
    from vehval.vehicle import load_vehicle

    c = load_vehicle(REFERENCE_VEHICLE).controller
    return tuple((k, 0.0 if k in _SOC_TERMS else float(getattr(c, k))) for k in RULE_KEYS)


def rule_params(vehicle: Any = None) -> dict[str, float]:
    """Rule parameters (:data:`RULE_KEYS`) of a vehicle's controller block; without a
    vehicle, those of :data:`REFERENCE_VEHICLE` with its SOC terms disabled (0)."""
    out = dict(_reference_rule())
    if vehicle is not None:
        c = vehicle.controller
        out.update({k: float(getattr(c, k)) for k in RULE_KEYS if hasattr(c, k)})
    return out


def rule_vector(params: dict[str, float]) -> np.ndarray:
    """Parameter vector (:data:`vehval.sim.layout.PARAMS` order, entries outside the rule 0)
    with ``params`` (controller keys; missing ones from :func:`rule_params`)."""
    base = rule_params()
    prm = np.zeros(len(PARAMS))
    for k, i in RULE_INDEX.items():
        prm[i] = float(params.get(k, base[k]))
    return prm


__all__ = ["REFERENCE_VEHICLE", "RULE_INDEX", "RULE_KEYS", "rule_params", "rule_vector"]
