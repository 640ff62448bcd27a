"""Replay of the simulator's engine on/off rule over signals rebuilt from a test.

The rule is the simulator's own: :func:`vehval.sim.supervisor.replay_rule` runs the one
compiled engine rule of the time loop (:func:`vehval.sim.supervisor.engine_rule`) over the
rebuilt inputs, with the parameters in the simulator's own vector. Total demand = wheel
power + auxiliary power + SOC-regulation power; the engine-on request is any of (total demand above ``engine_on_power_w`` for
``engine_on_power_hold_s``), (speed above ``engine_on_speed_mps`` for
``engine_on_speed_hold_s``), (battery unable to supply the wheel demand for
``battery_condition_hold_s``), (SOC below ``soc_engine_on`` for ``soc_engine_on_hold_s``);
the off request needs demand below ``engine_off_power_w``, speed below
``engine_off_speed_mps``, the battery able to supply and SOC at or above ``soc_engine_on``,
all for ``engine_off_hold_s``; the state machine then enforces the minimum on/off times.

Instead of the driver's internal demand (which a test does not record) the replay uses the
demand rebuilt from measured signals (:mod:`vehval.analysis.demand`), the measured speed and
the estimated SOC, so a rule estimated from a test can be compared with the observed engine
state step by step. The observed state trails the command by the engine's spin-up and
spin-down: :func:`replay` delays starts and stops separately.

The compiled kernels (the rule's, and the lagged agreement of
:mod:`vehval.analysis.replay_kernel`) are imported by the functions that run them: the
parameters alone (:func:`base_params`, :func:`rule_vector`) load no numba.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vehval.sim.rule import RULE_INDEX, RULE_KEYS, rule_params
from vehval.sim.rule import rule_vector as _rule_vector

__all__ = ["IDX", "RULE_KEYS", "agreement", "base_params", "replay", "rule_vector",
           "score_rule", "shift_state", "soc_power_demand_array"]

#: Position of each rule parameter (controller key) in the parameter vector.
IDX = dict(RULE_INDEX)


def __getattr__(name: str) -> Any:
    if name == "GENERIC":  # the rule without a vehicle (see vehval.sim.supervisor)
        return rule_params()
    raise AttributeError(name)


def rule_vector(params: dict[str, float]) -> np.ndarray:
    """Parameter dict (controller keys of :data:`RULE_KEYS`) -> the simulator's parameter
    vector (missing keys: :func:`base_params` without a vehicle)."""
    return _rule_vector(params)


def base_params(vehicle: Any = None) -> dict[str, float]:
    """Rule parameters from a vehicle's controller block, or the simulator's rule without a
    vehicle (:func:`vehval.sim.supervisor.rule_params`)."""
    return rule_params(vehicle)


def score_rule(p_wh: np.ndarray, v: np.ndarray, soc: np.ndarray, pdis_av: np.ndarray,
               aux_w: float, dt: float, prm: np.ndarray, state0: bool, obs: np.ndarray,
               valid: np.ndarray, lag_on: int, lag_off: int) -> float:
    """Agreement of the replayed rule with ``obs`` (fast path for the estimator).

    All arrays must already be float64 (``obs``, ``valid`` bool) with ``pdis_av`` finite
    (``inf`` for no limit); see :func:`replay` for the meaning of the arguments.
    """
    from vehval.analysis.replay_kernel import lagged_agreement
    from vehval.sim.supervisor import replay_rule

    out = replay_rule(p_wh, v, soc, pdis_av, aux_w, dt, prm, state0)
    return lagged_agreement(out, obs, valid, int(lag_on), int(lag_off))


def replay(p_wh: np.ndarray, v: np.ndarray, soc: np.ndarray, dt: float,
           params: dict[str, float] | np.ndarray, *, aux_w: float = 0.0,
           pdis_av_w: np.ndarray | None = None, state0: bool = False,
           lag_steps: int | tuple[int, int] = 0) -> np.ndarray:
    """Engine state commanded by the rule at every step.

    Parameters
    ----------
    p_wh : ndarray
        Wheel power demand [W] (NaN samples hold the last known value).
    v : ndarray
        Vehicle speed [m/s] (NaN samples hold the last known value).
    soc : ndarray
        State of charge [-] (NaN: SOC conditions and SOC regulation ignored).
    dt : float
        Step [s].
    params : dict or ndarray
        Rule parameters (keys of :data:`RULE_KEYS`; or a vector of :func:`rule_vector`).
    aux_w : float
        Auxiliary electrical load [W] added to the demand.
    pdis_av_w : ndarray, optional
        Battery discharge power available [W] (limit minus margin); default unlimited.
    state0 : bool
        Engine on at the first step.
    lag_steps : int or (int, int)
        Delay [steps] between the commanded state and the observable engine state (spin-up
        or spin-down of the engine, minus the delay of the measured inputs behind the
        controller's own: a negative value advances the replayed state); a pair gives the
        delays of the starts and of the stops separately.

    Returns
    -------
    ndarray of bool
    """
    from vehval.sim.supervisor import replay_rule

    prm = rule_vector(params) if isinstance(params, dict) else np.asarray(params, float)
    n = len(p_wh)
    pd = np.full(n, np.inf) if pdis_av_w is None else np.where(np.isfinite(pdis_av_w), pdis_av_w, np.inf)
    out = replay_rule(np.asarray(p_wh, float), np.asarray(v, float), np.asarray(soc, float),
                      pd.astype(float), float(aux_w), float(dt), prm, bool(state0))
    if isinstance(lag_steps, (tuple, list)):
        lag_on, lag_off = int(lag_steps[0]), int(lag_steps[1])
        a, b = shift_state(out, lag_on), shift_state(out, lag_off)
        # starts move by lag_on, stops by lag_off
        return (a | b) if lag_on <= lag_off else (a & b)
    return shift_state(out, int(lag_steps))


def shift_state(x: np.ndarray, k: int) -> np.ndarray:
    """``x`` delayed by ``k`` steps (advanced when negative), edges padded with the end values."""
    if k > 0:
        return np.concatenate([np.full(k, x[0]), x[:-k]])
    if k < 0:
        return np.concatenate([x[-k:], np.full(-k, x[-1])])
    return x


def agreement(observed: np.ndarray, replayed: np.ndarray, valid: np.ndarray | None = None) -> float:
    """Share [0..1] of (valid) time steps where the replayed and observed states agree."""
    m = np.ones(len(observed), bool) if valid is None else np.asarray(valid, bool)
    if not np.any(m):
        return float("nan")
    return float(np.mean(np.asarray(observed, bool)[m] == np.asarray(replayed, bool)[m]))


def soc_power_demand_array(soc: np.ndarray, params: dict) -> np.ndarray:
    """SOC-regulation power demand [W] at every step (0 where the SOC is unknown)."""
    p = params.get("soc_gain_w", 0.0) * (params.get("soc_target", 0.6) - np.asarray(soc, float))
    p = np.clip(p, -params.get("soc_discharge_power_max_w", 0.0), params.get("soc_charge_power_max_w", 0.0))
    return np.where(np.isfinite(p), p, 0.0)
