"""Engine on/off detection and operating-mode classification over time.

The engine state is read from the engine speed (a spinning engine is on) with hysteresis
between two speed thresholds and a debounce that removes runs shorter than a minimum
duration; without an engine speed it is read from the fuel rate the same way. Each time
step then gets one operating mode; consecutive steps of one mode form the timeline.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehval.constants import RPM_RAD_PER_S

RPM = RPM_RAD_PER_S  # [rad/s per rpm]

#: Operating modes, in the order used by tables and figures.
MODES = ("stopped", "ev_drive", "coast", "engine_idle", "engine_drive", "engine_charging",
         "engine_assist", "regen_braking", "friction_braking", "unknown")


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
                     on_rpm: float = 400.0, off_rpm: float = 250.0,
                     fuel_on_kg_s: float = 5.0e-5, fuel_off_kg_s: float = 2.0e-5,
                     debounce_s: float = 0.5) -> EngineState:
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
        state, valid = hysteresis(spd, on_rpm * RPM, off_rpm * RPM)
        method = (f"engine speed > {on_rpm:g} rpm on, < {off_rpm:g} rpm off, "
                  f"runs < {k * dt:g} s removed")
    elif fuel_rate is not None and np.any(np.isfinite(fuel_rate)):
        state, valid = hysteresis(np.asarray(fuel_rate, float), fuel_on_kg_s, fuel_off_kg_s)
        method = (f"fuel rate > {fuel_on_kg_s * 1e3:g} g/s on, < {fuel_off_kg_s * 1e3:g} g/s off, "
                  f"runs < {k * dt:g} s removed")
    else:
        return EngineState(np.zeros(t.size, bool), np.zeros(t.size, bool), "no engine speed or fuel rate")
    return EngineState(debounce(state, k), valid, method)


def classify_modes(v: np.ndarray, p_whl: np.ndarray, eng_on: np.ndarray,
                   ess_pwr: np.ndarray, eng_pwr: np.ndarray, *, stop_mps: float = 0.3,
                   drive_w: float = 500.0, batt_w: float = 1000.0, idle_w: float = 1500.0
                   ) -> np.ndarray:
    """One operating mode per step (index into :data:`MODES`).

    Rules, in priority order: ``stopped`` (v < ``stop_mps`` and engine off);
    ``engine_idle`` (engine on and engine power below ``idle_w``, or when the engine power
    is unknown, engine on while stopped); braking (wheel power < -``drive_w``):
    ``regen_braking`` if the battery is charging by more than ``batt_w``, else
    ``friction_braking``; engine off: ``ev_drive`` (wheel power > ``drive_w``) or
    ``coast``; engine on: ``engine_charging`` (battery charging by more than ``batt_w``),
    ``engine_assist`` (discharging by more than ``batt_w``) or ``engine_drive``. Steps with
    unknown wheel power are classified from speed and engine state only.

    Parameters
    ----------
    v : ndarray [m/s]
    p_whl : ndarray [W]
    eng_on : ndarray of bool
    ess_pwr : ndarray [W] (> 0 discharging)
    eng_pwr : ndarray [W]

    Returns
    -------
    ndarray of int
    """
    n = v.size
    code = {m: i for i, m in enumerate(MODES)}
    out = np.full(n, code["unknown"])
    vk = np.isfinite(v)
    pk = np.isfinite(p_whl)
    bk = np.isfinite(ess_pwr)
    ek = np.isfinite(eng_pwr)
    stopped = vk & (v < stop_mps)
    brake = pk & (p_whl < -drive_w) & ~stopped
    charging = bk & (ess_pwr < -batt_w)
    assist = bk & (ess_pwr > batt_w)
    idle = eng_on & ((ek & (eng_pwr < idle_w) & ~brake) | (~ek & stopped))
    out[~eng_on & vk & ~stopped] = code["coast"]
    out[~eng_on & pk & (p_whl > drive_w) & ~stopped] = code["ev_drive"]
    out[eng_on & vk] = code["engine_drive"]
    out[eng_on & charging] = code["engine_charging"]
    out[eng_on & assist] = code["engine_assist"]
    out[brake & charging] = code["regen_braking"]
    out[brake & ~charging] = code["friction_braking"]
    out[idle] = code["engine_idle"]
    out[stopped & ~eng_on] = code["stopped"]
    return out


def timeline(t: np.ndarray, codes: np.ndarray, min_s: float = 1.0) -> list[dict]:
    """Mode segments ``{mode, start_s, end_s, duration_s}``; segments shorter than ``min_s``
    [s] are merged into their neighbours (the longer neighbour wins)."""
    if t.size == 0:
        return []
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    c = np.asarray(codes).copy()
    k = max(1, round(min_s / dt))
    starts, lengths, vals = run_lengths(c)
    # absorb short segments into the previous segment (one pass keeps it O(n))
    merged: list[list[int]] = []
    for st, ln, val in zip(starts, lengths, vals):
        if merged and (ln < k or merged[-1][2] == val):
            merged[-1][1] += int(ln)
        else:
            merged.append([int(st), int(ln), int(val)])
    out = []
    for st, ln, val in merged:
        end = min(st + ln, t.size - 1)
        out.append({"mode": MODES[val], "start_s": round(float(t[st]), 3),
                    "end_s": round(float(t[end]) if st + ln < t.size else float(t[-1] + dt), 3),
                    "duration_s": round(ln * dt, 3)})
    return out


def mode_shares(codes: np.ndarray, dt: float) -> dict[str, dict]:
    """Time [s] and share [0..1] of each mode."""
    n = max(int(np.asarray(codes).size), 1)
    out = {}
    for i, m in enumerate(MODES):
        cnt = int(np.sum(codes == i))
        out[m] = {"time_s": round(cnt * dt, 3), "share": round(cnt / n, 4)}
    return out
