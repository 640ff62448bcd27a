"""Engine on/off events and the conditions at each transition."""

from __future__ import annotations

import numpy as np

from vehval.analysis.replay import soc_power_demand_array


def transitions(on: np.ndarray, valid: np.ndarray) -> list[tuple[int, str]]:
    """Indices of observed engine starts and stops (both neighbours valid)."""
    on = np.asarray(on, bool)
    idx = np.nonzero(on[1:] != on[:-1])[0] + 1
    return [(int(i), "on" if on[i] else "off") for i in idx if valid[i] and valid[i - 1]]


def event_table(t: np.ndarray, on: np.ndarray, valid: np.ndarray, v: np.ndarray,
                p_whl: np.ndarray, soc: np.ndarray, ess_pwr: np.ndarray, params: dict,
                aux_w: float = 0.0, lag_s: float = 0.0) -> list[dict]:
    """One record per engine start/stop with the conditions just before it.

    Conditions are read ``lag_s`` + 0.5 s before the observed transition (the command
    precedes the observed state). ``cause`` names which engine-on conditions of the rule
    (with ``params``) held in the second before that: power, speed, soc; ``min_time`` when none held (the
    transition was released by the end of a minimum time or a hold).

    Returns
    -------
    list of dict
        ``{type, time_s, speed_mps, wheel_power_w, total_demand_w, soc, ess_pwr_w,
        since_last_s, cause}``.
    """
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    back = round((lag_s + 0.5) / dt)
    p_soc = soc_power_demand_array(soc, params)
    out, last = [], None
    for i, kind in transitions(on, valid):
        j = max(i - back, 0)
        p_tot = (p_whl[j] if np.isfinite(p_whl[j]) else np.nan) + aux_w + p_soc[j]
        win = slice(max(j - round(1.0 / dt), 0), i + 1)
        pw = p_whl[win] + aux_w + p_soc[win]
        p_max = np.nanmax(pw) if np.any(np.isfinite(pw)) else np.nan
        v_max = np.nanmax(v[win]) if np.any(np.isfinite(v[win])) else np.nan
        causes = []
        if kind == "on":
            if np.isfinite(p_max) and p_max > params["engine_on_power_w"]:
                causes.append("power")
            if np.isfinite(v_max) and v_max > params["engine_on_speed_mps"]:
                causes.append("speed")
            if np.isfinite(soc[j]) and soc[j] < params.get("soc_engine_on", 0.0):
                causes.append("soc")
        else:
            if np.isfinite(p_tot) and p_tot < params["engine_off_power_w"]:
                causes.append("low_power")
            if np.isfinite(v[j]) and v[j] < params["engine_off_speed_mps"]:
                causes.append("low_speed")
        rec = {"type": kind, "time_s": round(float(t[i]), 3),
               "speed_mps": _r(v[j]), "wheel_power_w": _r(p_whl[j]), "total_demand_w": _r(p_tot),
               "soc": _r(soc[j], 4), "ess_pwr_w": _r(ess_pwr[j]),
               "since_last_s": None if last is None else round(float(t[i] - t[last]), 3),
               "cause": "+".join(causes) if causes else "min_time_or_hold"}
        out.append(rec)
        last = i
    return out


def _r(x: float, nd: int = 2):
    return None if not np.isfinite(x) else round(float(x), nd)
