"""Engine on/off detection and operating-mode classification over time.

The engine state is read from the engine speed (a spinning engine is on) with hysteresis
between two speed thresholds and a debounce that removes runs shorter than a minimum
duration; without an engine speed it is read from the fuel rate the same way. Each time
step then gets one operating mode; consecutive steps of one mode form the timeline.
"""

from __future__ import annotations

import numpy as np

from vehval.equations.engine_state import (  # noqa: F401 - the engine state's owner, re-exported
    EngineState,
    debounce,
    detect_engine_on,
    hysteresis,
    run_lengths,
)

#: Operating modes, in the order used by tables and figures.
MODES = ("stopped", "ev_drive", "coast", "engine_idle", "engine_drive", "engine_charging",
         "engine_assist", "regen_braking", "friction_braking", "unknown")


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
