"""Engine on/off from measured data: the one rule for every stage.

The engine is **on while it spins**: its measured speed rises above
:data:`ENGINE_ON_RPM` (400 rpm) and it is off again once the speed falls below
:data:`ENGINE_OFF_RPM` (250 rpm); runs shorter than :data:`DEBOUNCE_S` are merged into
their neighbours. Without an engine speed the fuel rate decides the same way.

Why this rule and not a single threshold: a running engine idles at 600-1000 rpm and a
stopped one reads 0 (a crankshaft sensor gives no speed at rest), so both thresholds lie
well below idle and well above sensor noise; cranking (about 200-300 rpm) is not yet
running, and a spin-down counts as running until the speed has nearly gone, which is when
the engine stops firing. The two thresholds keep a speed that dithers around one value
from counting dozens of starts, and the debounce removes one-sample dropouts and spikes
of 1-10 Hz loggers. A lab defends it as "the engine turns at least at cranking speed": a
start counted by it is a start of the engine, as an emissions lab counts cold and hot
starts. The engine speed is preferred to the fuel rate because fuel cut-off in a
deceleration leaves a spinning engine with no fuel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehval.constants import RPM_RAD_PER_S

__all__ = ["DEBOUNCE_S", "ENGINE_OFF_RPM", "ENGINE_ON_RPM", "EngineState", "debounce",
           "detect_engine_on", "engine_running", "hysteresis", "run_lengths"]

#: Engine speed above which a stopped engine counts as started [rpm].
ENGINE_ON_RPM = 400.0
#: Engine speed below which a running engine counts as stopped [rpm].
ENGINE_OFF_RPM = 250.0
#: Shortest on or off run kept [s]; shorter runs merge into their neighbours.
DEBOUNCE_S = 0.5
#: Fuel rate thresholds used without an engine speed [kg/s] (idle burns about 1e-4 kg/s).
FUEL_ON_KG_S = 5.0e-5
FUEL_OFF_KG_S = 2.0e-5


@dataclass
class EngineState:
    """Detected engine state on the analysis grid.

    Attributes
    ----------
    on : ndarray of bool
        Engine on (spinning / fuelled) at each step.
    valid : ndarray of bool
        Steps where the detector had data.
    method : str
        What the state was read from, with the thresholds.
    """

    on: np.ndarray
    valid: np.ndarray
    method: str


def run_lengths(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run-length encoding: (start index, length, value) of each run of equal values."""
    x = np.asarray(x)
    if x.size == 0:
        return np.zeros(0, int), np.zeros(0, int), x[:0]
    change = np.nonzero(x[1:] != x[:-1])[0] + 1
    starts = np.concatenate([[0], change])
    lengths = np.diff(np.concatenate([starts, [x.size]]))
    return starts, lengths, x[starts]


def hysteresis(x: np.ndarray, on_above: float, off_below: float, initial: bool | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Two-threshold switch: on once ``x > on_above``, off once ``x < off_below``.

    NaN samples hold the previous state and are flagged invalid.

    Returns
    -------
    state : ndarray of bool
    valid : ndarray of bool
    """
    x = np.asarray(x, float)
    valid = np.isfinite(x)
    state = np.zeros(x.size, bool)
    cur = bool(initial) if initial is not None else bool(valid.any() and x[valid][0] > 0.5 * (on_above + off_below))
    for i, xi in enumerate(x):
        if xi == xi:
            if cur and xi < off_below:
                cur = False
            elif not cur and xi > on_above:
                cur = True
        state[i] = cur
    return state, valid


def debounce(state: np.ndarray, min_steps: int) -> np.ndarray:
    """Remove runs shorter than ``min_steps`` (merged into their neighbours), shortest first."""
    s = np.asarray(state, bool).copy()
    if min_steps <= 1 or s.size == 0:
        return s
    while True:
        starts, lengths, _vals = run_lengths(s)
        inner = [(ln, st) for st, ln in zip(starts, lengths) if ln < min_steps]
        if len(starts) <= 1 or not inner:
            return s
        ln, st = min(inner)
        s[st:st + ln] = ~s[st]


def detect_engine_on(t: np.ndarray, eng_spd: np.ndarray, fuel_rate: np.ndarray | None = None, *,
                     on_rpm: float = ENGINE_ON_RPM, off_rpm: float = ENGINE_OFF_RPM,
                     fuel_on_kg_s: float = FUEL_ON_KG_S, fuel_off_kg_s: float = FUEL_OFF_KG_S,
                     debounce_s: float = DEBOUNCE_S) -> EngineState:
    """Engine on/off from engine speed (preferred) or fuel rate, with hysteresis and debounce.

    Parameters
    ----------
    t : ndarray
        Uniform time grid [s].
    eng_spd : ndarray
        Engine speed [rad/s] (NaN where unknown).
    fuel_rate : ndarray, optional
        Fuel mass rate [kg/s], used when the engine speed is missing.
    on_rpm, off_rpm : float
        Hysteresis thresholds on engine speed [rpm]: well below idle (about 1000 rpm) and
        well above sensor noise, so spin-up and spin-down count as half-way.
    fuel_on_kg_s, fuel_off_kg_s : float
        Hysteresis thresholds on fuel rate [kg/s] (idle burns about 1e-4 kg/s).
    debounce_s : float
        Runs shorter than this [s] are merged into their neighbours.

    Returns
    -------
    EngineState
    """
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    k = max(1, int(np.ceil(debounce_s / dt - 1e-9)))
    spd = np.asarray(eng_spd, float)
    if np.any(np.isfinite(spd)):
        state, valid = hysteresis(spd, on_rpm * RPM_RAD_PER_S, off_rpm * RPM_RAD_PER_S)
        method = (f"engine speed > {on_rpm:g} rpm on, < {off_rpm:g} rpm off, "
                  f"runs < {k * dt:g} s removed")
    elif fuel_rate is not None and np.any(np.isfinite(fuel_rate)):
        state, valid = hysteresis(np.asarray(fuel_rate, float), fuel_on_kg_s, fuel_off_kg_s)
        method = (f"fuel rate > {fuel_on_kg_s * 1e3:g} g/s on, < {fuel_off_kg_s * 1e3:g} g/s off, "
                  f"runs < {k * dt:g} s removed")
    else:
        return EngineState(np.zeros(t.size, bool), np.zeros(t.size, bool), "no engine speed or fuel rate")
    return EngineState(debounce(state, k), valid, method)


def engine_running(t: np.ndarray, eng_spd: np.ndarray) -> np.ndarray:
    """Engine on (True), off (False) at each sample of a measured engine speed [rad/s] at
    times ``t`` [s], by the rule of the module docstring; NaN samples hold the state."""
    return detect_engine_on(np.asarray(t, float), np.asarray(eng_spd, float)).on
