"""The engine on/off rule of the supervisory controller, shared by the loop and the replay.

:func:`engine_rule` is the one implementation: total demand = wheel power + auxiliary power
+ SOC-regulation power; the engine-on request is any of (total demand above
``engine_on_power_w`` for ``engine_on_power_hold_s``), (speed above ``engine_on_speed_mps``
for ``engine_on_speed_hold_s``), (battery unable to supply the wheel demand for
``battery_condition_hold_s``), (SOC below ``soc_engine_on`` for ``soc_engine_on_hold_s``);
the off request needs demand below ``engine_off_power_w``, speed below
``engine_off_speed_mps``, the battery able to supply and SOC at or above ``soc_engine_on``,
all for ``engine_off_hold_s``; the state machine (:mod:`vehval.sim.control`) then enforces
the minimum on/off times. A SOC of NaN (unknown) disables SOC regulation and the SOC
conditions. The time loop (:mod:`vehval.sim.phases`) calls it every step; :func:`replay_rule`
runs it over signals rebuilt from a test (:mod:`vehval.analysis.replay`).

Parameters come in the loop's own vector (:data:`vehval.sim.layout.PARAMS`, of which the
rule reads :data:`RULE_KEYS`), the state in its state vector (:data:`vehval.sim.layout.STATE`).
The parameters' keys, positions and values are in :mod:`vehval.sim.rule` (no compiled code:
importing this module loads numba, that one does not); they are re-exported here.
"""

from __future__ import annotations

import numpy as np

from vehval.numba_cache import njit
from vehval.sim.control import (
    ENG_OFF,
    ENG_ON,
    engine_commanded_on,
    held,
    hold_timer,
    soc_power_demand,
    state_step,
)
from vehval.sim.indices import *  # noqa: F401,F403 - index constants
from vehval.sim.layout import STATE
from vehval.sim.rule import (
    REFERENCE_VEHICLE,
    RULE_INDEX,
    RULE_KEYS,
    rule_params,
    rule_vector,
)
from vehval.sim.stack import stack_vector


@njit(cache=True, inline="always")
def engine_rule(prm, x):
    """One step of the engine on/off rule.

    Reads from the state ``x``: wheel power demand ``p_wh`` [W], speed ``v0`` [m/s],
    ``soc`` [-] (NaN: unknown), discharge power available ``pdis_av`` [W], time ``t`` [s]
    (the engine is held on while ``t < hold_s``) and step ``dt`` [s]; updates the five
    condition timers [s], ``eng_state``, ``eng_state_time`` [s] and the total demand
    ``p_tot`` [W].
    """
    dt = x[X_DT]
    p_wh = x[X_P_WH]
    v0 = x[X_V0]
    soc = x[X_SOC]
    aux = prm[P_AUX_W]
    soc_ok = soc == soc
    p_bdem = soc_power_demand(soc, prm[P_SOC_TARGET], prm[P_SOC_GAIN], prm[P_SOC_PCHG_MAX],
                              prm[P_SOC_PDIS_MAX]) if soc_ok else 0.0
    p_tot = p_wh + aux + p_bdem
    c_bat = max(p_wh, 0.0) / prm[P_ELEC_EFF] + aux > x[X_PDIS_AV]
    low_soc = soc_ok and soc < prm[P_SOC_ON]
    x[X_TM_PWR] = hold_timer(x[X_TM_PWR], p_tot > prm[P_ON_PWR], dt)
    x[X_TM_SPD] = hold_timer(x[X_TM_SPD], v0 > prm[P_ON_SPD], dt)
    x[X_TM_BAT] = hold_timer(x[X_TM_BAT], c_bat, dt)
    x[X_TM_SOC] = hold_timer(x[X_TM_SOC], low_soc, dt)
    on_req = (held(x[X_TM_PWR], prm[P_ON_PWR_HOLD]) or held(x[X_TM_SPD], prm[P_ON_SPD_HOLD])
              or held(x[X_TM_BAT], prm[P_BATT_HOLD]) or held(x[X_TM_SOC], prm[P_SOC_ON_HOLD]))
    off_raw = p_tot < prm[P_OFF_PWR] and v0 < prm[P_OFF_SPD] and (not c_bat) and (not low_soc)
    x[X_TM_OFF] = hold_timer(x[X_TM_OFF], off_raw, dt)
    off_req = held(x[X_TM_OFF], prm[P_OFF_HOLD])
    force = (soc_ok and soc < prm[P_SOC_FORCE]) or x[X_T] < x[X_HOLD_S]
    st, tst = state_step(int(x[X_ENG_STATE]), x[X_ENG_STATE_TIME], on_req, off_req, force,
                         dt, prm[P_MIN_ON], prm[P_MIN_OFF])
    x[X_ENG_STATE] = st
    x[X_ENG_STATE_TIME] = tst
    x[X_P_TOT] = p_tot


@njit(cache=True)
def replay_rule(p_wh, v, soc, pdis_av, aux, dt, prm, state0):
    """Engine state commanded by :func:`engine_rule` at every step of measured inputs.

    Parameters
    ----------
    p_wh, v, soc, pdis_av : ndarray
        Wheel power demand [W], speed [m/s] (NaN samples of both hold the last known
        value), SOC [-] (NaN: unknown) and discharge power available [W] per step.
    aux : float
        Auxiliary electrical load [W].
    dt : float
        Step [s].
    prm : ndarray
        Parameter vector (:data:`vehval.sim.layout.PARAMS`; the rule reads
        :data:`RULE_KEYS`).
    state0 : bool
        Engine on at the first step.

    Returns
    -------
    ndarray of bool
    """
    n = p_wh.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    q = prm.copy()
    q[P_AUX_W] = aux
    x = stack_vector(N_X)
    x[X_DT] = dt
    x[X_ENG_STATE] = ENG_ON if state0 else ENG_OFF
    x[X_ENG_STATE_TIME] = 1e9
    for i in range(n):
        out[i] = engine_commanded_on(int(x[X_ENG_STATE]))
        if p_wh[i] == p_wh[i]:
            x[X_P_WH] = p_wh[i]
        if v[i] == v[i]:
            x[X_V0] = v[i]
        x[X_SOC] = soc[i]
        x[X_PDIS_AV] = pdis_av[i]
        engine_rule(q, x)
    return out


__all__ = ["REFERENCE_VEHICLE", "RULE_INDEX", "RULE_KEYS", "STATE", "engine_rule",
           "replay_rule", "rule_params", "rule_vector"]
