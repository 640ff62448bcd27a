"""Engine operating points against the best-efficiency line, and power distributions.

With a vehicle, the best line is computed from its fuel map
(:attr:`vehval.vehicle.Vehicle.best_line`); each engine-on step's torque is compared
with the line's torque at the same speed. Departures are attributed to the battery power
limit (battery power within 5 % of its limit), to a transient (|d P_eng/dt| above 5 kW/s)
or to low power (below 5 kW), in that order; the rest is "other".
"""

from __future__ import annotations

import numpy as np

from vehval.analysis.modes import MODES
from vehval.constants import RPM_RAD_PER_S


def operating_points(eng_spd: np.ndarray, eng_trq: np.ndarray, eng_on: np.ndarray, dt: float,
                     vehicle=None, ess_pwr: np.ndarray | None = None,
                     pdis_lim: np.ndarray | None = None, pchg_lim: np.ndarray | None = None,
                     band_nm: float = 10.0) -> dict:
    """Distance of engine operating points from the best-efficiency line.

    Parameters
    ----------
    eng_spd : ndarray [rad/s]
    eng_trq : ndarray [N·m]
    eng_on : ndarray of bool
    dt : float [s]
    vehicle : Vehicle, optional
    ess_pwr, pdis_lim, pchg_lim : ndarray [W], optional
        Battery power and its discharge / charge limits (positive numbers).
    band_nm : float
        Half-width [N·m] of the band counted as "on the line".

    Returns
    -------
    dict
    """
    ok = np.asarray(eng_on, bool) & np.isfinite(eng_spd) & np.isfinite(eng_trq) & (eng_spd > 50.0)
    out: dict = {"n": int(ok.sum()), "band_nm": band_nm}
    if not ok.any():
        out["why"] = "no engine-on steps with engine speed and torque"
        return out
    w, tq = eng_spd[ok], eng_trq[ok]
    p = w * tq
    out["points"] = {"speed_rpm": (w / RPM_RAD_PER_S)[:: max(1, ok.sum() // 2000)].round(1).tolist(),
                     "torque_nm": tq[:: max(1, ok.sum() // 2000)].round(2).tolist()}
    if vehicle is None:
        out["why"] = "no vehicle: best-efficiency line unknown"
        return out
    _pw, ws, ts = vehicle.best_line
    order = np.argsort(ws)
    ws_u, idx = np.unique(ws[order], return_index=True)
    t_line = np.interp(w, ws_u, ts[order][idx])
    dist = tq - t_line
    within = np.abs(dist) <= band_nm
    pe = np.full(eng_spd.size, np.nan)
    pe[ok] = p
    dpdt = np.abs(np.gradient(np.nan_to_num(pe), dt))[ok]
    cause = np.full(w.size, "other", dtype=object)
    if ess_pwr is not None and pdis_lim is not None and pchg_lim is not None:
        pb = ess_pwr[ok]
        at_lim = (np.isfinite(pb) & ((pb > 0.95 * pdis_lim[ok]) | (pb < -0.95 * pchg_lim[ok])))
        cause[at_lim] = "battery_limit"
    cause[(cause == "other") & (dpdt > 5000.0)] = "transient"
    cause[(cause == "other") & (p < 5000.0)] = "low_power"
    cause[within] = "on_line"
    out.update({
        "share_within_band": float(np.mean(within)),
        "torque_distance_nm": {"mean": float(np.mean(dist)), "median": float(np.median(dist)),
                               "p95_abs": float(np.quantile(np.abs(dist), 0.95))},
        "departure_causes": {c: float(np.mean(cause == c)) for c in
                             ("on_line", "battery_limit", "transient", "low_power", "other")},
        "best_line": {"speed_rpm": (ws / RPM_RAD_PER_S).round(1).tolist(), "torque_nm": ts.round(2).tolist()},
    })
    return out


def power_histogram_by_mode(eng_pwr: np.ndarray, modes: np.ndarray, eng_on: np.ndarray,
                            bin_w: float = 2000.0) -> dict:
    """Engine power distribution per mode (time in each power bin [s/step counts])."""
    ok = np.asarray(eng_on, bool) & np.isfinite(eng_pwr)
    if not ok.any():
        return {"why": "no engine power (measured or from speed x torque)"}
    hi = max(bin_w, float(np.ceil(np.max(eng_pwr[ok]) / bin_w) * bin_w))
    edges = np.arange(min(0.0, float(np.floor(np.min(eng_pwr[ok]) / bin_w) * bin_w)), hi + bin_w, bin_w)
    counts = {}
    for i, m in enumerate(MODES):
        sel = ok & (modes == i)
        if sel.any():
            counts[m] = np.histogram(eng_pwr[sel], edges)[0].tolist()
    return {"edges_w": edges.tolist(), "counts": counts}


def current_histogram(ess_curr: np.ndarray, mask: np.ndarray, bin_a: float = 5.0) -> dict:
    """Battery current distribution [A] over the masked steps (e.g. regenerative braking)."""
    c = ess_curr[np.asarray(mask, bool) & np.isfinite(ess_curr)]
    if c.size == 0:
        return {"why": "no battery current in the selected steps"}
    lo = float(np.floor(c.min() / bin_a) * bin_a)
    hi = float(np.ceil(c.max() / bin_a) * bin_a) + bin_a
    edges = np.arange(lo, hi + bin_a / 2, bin_a)
    return {"edges_a": edges.tolist(), "counts": np.histogram(c, edges)[0].tolist(), "n": int(c.size),
            "median_a": float(np.median(c)), "min_a": float(c.min())}
