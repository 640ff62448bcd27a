"""Supervisory controller: the engine on/off state machine and its parameters.

States (named as in the paper): ``Eng_Off``, ``Eng_Off_MinTime``, ``Eng_On``,
``Eng_On_MinTime``. Each engine-on condition (total power demand, vehicle speed, battery
unable to supply the demand, low SOC) counts only after it has held for its own hold time;
the engine-off request likewise. After a switch the engine stays in the new state for a
minimum time; only a critically low SOC may cut the minimum off time short.

The step functions are compiled with numba and called from the time loop in
:mod:`vehval.sim.kernel`; they are plain functions of their inputs, so tests call them
directly with crafted inputs.
"""

from __future__ import annotations

from vehval.numba_cache import njit

ENG_OFF = 0
ENG_OFF_MINTIME = 1
ENG_ON = 2
ENG_ON_MINTIME = 3
STATE_NAMES = ("Eng_Off", "Eng_Off_MinTime", "Eng_On", "Eng_On_MinTime")

PROPEL_NORMAL = 0
PROPEL_DISCHARGE_LIMIT = 1
PROPEL_CHARGE_LIMIT = 2
PROPEL_BRAKING = 3


@njit(cache=True)
def hold_timer(timer, condition, dt):
    """Time [s] a condition has held: ``timer + dt`` while true, reset to 0 when false."""
    if condition:
        return timer + dt
    return 0.0


@njit(cache=True)
def held(timer, hold_s):
    """True once a condition timer [s] has reached its hold time [s] (1 µs tolerance)."""
    return timer >= hold_s - 1e-6


@njit(cache=True)
def state_step(state, t_state, on_request, off_request, force_on, dt, min_on_s, min_off_s):
    """One step of the engine state machine.

    Parameters
    ----------
    state : int
        Current state (ENG_OFF, ENG_OFF_MINTIME, ENG_ON, ENG_ON_MINTIME).
    t_state : float
        Time spent in the current state [s] before this step.
    on_request, off_request : bool
        Engine-on / engine-off requests (already held for their hold times).
    force_on : bool
        SOC critically low: the engine must run, even during the minimum off time.
    dt : float
        Step [s].
    min_on_s, min_off_s : float
        Minimum on and off times [s].

    Returns
    -------
    (new_state, new_t_state) : (int, float)
    """
    t = t_state + dt
    if state == ENG_OFF:
        if on_request or force_on:
            return ENG_ON_MINTIME, 0.0
        return ENG_OFF, t
    if state == ENG_ON_MINTIME:
        if t >= min_on_s - 1e-6:
            return ENG_ON, t
        return ENG_ON_MINTIME, t
    if state == ENG_ON:
        if off_request and not force_on:
            return ENG_OFF_MINTIME, 0.0
        return ENG_ON, t
    # ENG_OFF_MINTIME
    if force_on:
        return ENG_ON_MINTIME, 0.0
    if t >= min_off_s - 1e-6:
        return ENG_OFF, t
    return ENG_OFF_MINTIME, t


@njit(cache=True)
def engine_commanded_on(state):
    """True in the two engine-on states."""
    return state == ENG_ON or state == ENG_ON_MINTIME


@njit(cache=True)
def soc_power_demand(soc, soc_target, gain_w, charge_max_w, discharge_max_w):
    """Battery power demand [W] from SOC regulation (> 0 asks the engine to charge)."""
    p = gain_w * (soc_target - soc)
    if p > charge_max_w:
        return charge_max_w
    if p < -discharge_max_w:
        return -discharge_max_w
    return p


@njit(cache=True)
def regen_fade(speed, fade_low, fade_high):
    """Fraction [0..1] of regenerative braking allowed at ``speed`` [m/s] (linear fade-out)."""
    f = (speed - fade_low) / (fade_high - fade_low)
    return min(max(f, 0.0), 1.0)
