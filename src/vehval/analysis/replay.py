"""Replay of the simulator's engine on/off rule over signals rebuilt from a test.

The rule is the same as the supervisory controller of :mod:`vehval.sim.kernel` (it calls
the simulator's own compiled ``hold_timer``, ``held``, ``soc_power_demand`` and
``state_step``): total demand = wheel power + auxiliary power + SOC-regulation power; the
engine-on request is any of (total demand above ``engine_on_power_w`` for
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
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from vehval.sim.control import (
    engine_commanded_on,
    held,
    hold_timer,
    soc_power_demand,
    state_step,
)

#: Parameters of the rule, in the vehicle file's controller keys (order of the array).
RULE_KEYS = (
    "engine_on_power_w", "engine_off_power_w", "engine_on_speed_mps", "engine_off_speed_mps",
    "min_on_time_s", "min_off_time_s", "engine_on_power_hold_s", "engine_on_speed_hold_s",
    "engine_off_hold_s", "battery_condition_hold_s", "soc_engine_on", "soc_engine_on_hold_s",
    "soc_force_on", "soc_target", "soc_gain_w", "soc_charge_power_max_w",
    "soc_discharge_power_max_w", "electric_drive_efficiency",
)
IDX = {k: i for i, k in enumerate(RULE_KEYS)}

#: Values used when neither a vehicle nor an estimate gives a parameter (the 2004 Prius
#: file's values for hold times and SOC regulation; SOC conditions disabled).
GENERIC = {
    "engine_on_power_w": 8000.0, "engine_off_power_w": 3000.0, "engine_on_speed_mps": 19.0,
    "engine_off_speed_mps": 17.0, "min_on_time_s": 5.0, "min_off_time_s": 3.0,
    "engine_on_power_hold_s": 0.5, "engine_on_speed_hold_s": 0.5, "engine_off_hold_s": 2.0,
    "battery_condition_hold_s": 0.2, "soc_engine_on": 0.0, "soc_engine_on_hold_s": 1.0,
    "soc_force_on": 0.0, "soc_target": 0.6, "soc_gain_w": 0.0, "soc_charge_power_max_w": 0.0,
    "soc_discharge_power_max_w": 0.0, "electric_drive_efficiency": 0.85,
}


def rule_vector(params: dict[str, float]) -> np.ndarray:
    """Parameter dict -> float array in :data:`RULE_KEYS` order (missing keys: GENERIC)."""
    return np.array([float(params.get(k, GENERIC[k])) for k in RULE_KEYS])


def base_params(vehicle: Any = None) -> dict[str, float]:
    """Rule parameters from a vehicle's controller block, or the generic defaults."""
    out = dict(GENERIC)
    if vehicle is not None:
        c = vehicle.controller
        out.update({k: float(getattr(c, k)) for k in RULE_KEYS if hasattr(c, k)})
    return out


@njit(cache=True)
def _replay(p_wh, v, soc, pdis_av, aux, dt, prm, state0):
    n = p_wh.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    st = 2 if state0 else 0
    tst = 1e9
    tm_pwr = 0.0
    tm_spd = 0.0
    tm_bat = 0.0
    tm_soc = 0.0
    tm_off = 0.0
    on_pwr = prm[0]; off_pwr = prm[1]; on_spd = prm[2]; off_spd = prm[3]
    min_on = prm[4]; min_off = prm[5]; h_pwr = prm[6]; h_spd = prm[7]; h_off = prm[8]
    h_bat = prm[9]; soc_on = prm[10]; h_soc = prm[11]; soc_force = prm[12]
    pw = 0.0
    vi = 0.0
    for i in range(n):
        out[i] = engine_commanded_on(st)
        # unknown samples (NaN) hold the last known value
        if p_wh[i] == p_wh[i]:
            pw = p_wh[i]
        if v[i] == v[i]:
            vi = v[i]
        si = soc[i]
        soc_ok = si == si
        p_bdem = soc_power_demand(si, prm[13], prm[14], prm[15], prm[16]) if soc_ok else 0.0
        p_tot = pw + aux + p_bdem
        c_bat = max(pw, 0.0) / prm[17] + aux > pdis_av[i]
        low_soc = soc_ok and si < soc_on
        tm_pwr = hold_timer(tm_pwr, p_tot > on_pwr, dt)
        tm_spd = hold_timer(tm_spd, vi > on_spd, dt)
        tm_bat = hold_timer(tm_bat, c_bat, dt)
        tm_soc = hold_timer(tm_soc, low_soc, dt)
        on_req = (held(tm_pwr, h_pwr) or held(tm_spd, h_spd) or held(tm_bat, h_bat)
                  or held(tm_soc, h_soc))
        off_raw = p_tot < off_pwr and vi < off_spd and (not c_bat) and (not low_soc)
        tm_off = hold_timer(tm_off, off_raw, dt)
        off_req = held(tm_off, h_off)
        force = soc_ok and si < soc_force
        st, tst = state_step(st, tst, on_req, off_req, force, dt, min_on, min_off)
    return out


@njit(cache=True)
def _lagged_agreement(x, obs, valid, lag_on, lag_off):
    """Share of valid steps where ``x`` delayed by (lag_on at starts, lag_off at stops)
    equals ``obs`` (the compiled equivalent of :func:`shift_state` + :func:`agreement`)."""
    n = x.shape[0]
    hit = 0
    cnt = 0
    for i in range(n):
        if not valid[i]:
            continue
        ja = min(max(i - lag_on, 0), n - 1)
        jb = min(max(i - lag_off, 0), n - 1)
        if lag_on <= lag_off:
            y = x[ja] or x[jb]
        else:
            y = x[ja] and x[jb]
        cnt += 1
        if y == obs[i]:
            hit += 1
    if cnt == 0:
        return np.nan
    return hit / cnt


def score_rule(p_wh: np.ndarray, v: np.ndarray, soc: np.ndarray, pdis_av: np.ndarray,
               aux_w: float, dt: float, prm: np.ndarray, state0: bool, obs: np.ndarray,
               valid: np.ndarray, lag_on: int, lag_off: int) -> float:
    """Agreement of the replayed rule with ``obs`` (fast path for the estimator).

    All arrays must already be float64 (``obs``, ``valid`` bool) with ``pdis_av`` finite
    (``inf`` for no limit); see :func:`replay` for the meaning of the arguments.
    """
    out = _replay(p_wh, v, soc, pdis_av, aux_w, dt, prm, state0)
    return _lagged_agreement(out, obs, valid, int(lag_on), int(lag_off))


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
        Rule parameters (keys of :data:`RULE_KEYS`; array in that order).
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
    prm = rule_vector(params) if isinstance(params, dict) else np.asarray(params, float)
    n = len(p_wh)
    pd = np.full(n, np.inf) if pdis_av_w is None else np.where(np.isfinite(pdis_av_w), pdis_av_w, np.inf)
    out = _replay(np.asarray(p_wh, float), np.asarray(v, float), np.asarray(soc, float),
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
