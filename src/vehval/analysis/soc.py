"""SOC regulation: battery power as a function of the SOC, fitted robustly.

While the engine runs in steady propulsion the battery supplies (or absorbs) the SOC
regulation power ``P_batt ≈ -gain · (soc_target - soc)`` (> 0 discharging). A robust
linear fit ``P_batt = slope · soc + intercept`` (soft-L1 loss) gives ``soc_gain_w ≈ slope``
and ``soc_target ≈ -intercept / slope``. The battery-side slope is lower than the
controller's gain by the engine-to-battery path efficiency, which the report states.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def fit_soc_regulation(soc: np.ndarray, ess_pwr: np.ndarray, eng_on: np.ndarray,
                       p_whl: np.ndarray, dt: float, *, min_points: int = 30) -> dict:
    """Fit battery power [W] against SOC [-] during steady engine-on propulsion.

    Parameters
    ----------
    soc, ess_pwr, eng_on, p_whl : ndarray
        SOC [-], battery power [W] (> 0 discharging), engine state, wheel power [W].
    dt : float
        Step [s].
    min_points : int
        Fewer usable steps than this and no fit is attempted.

    Returns
    -------
    dict
        ``slope_w`` [W per unit SOC], ``intercept_w`` [W], ``soc_target``, ``soc_gain_w``,
        ``r2``, ``n``, ``soc_range``, binned medians for a figure, or ``{"fitted": False, "why"}``.
    """
    soc = np.asarray(soc, float)
    pb = np.asarray(ess_pwr, float)
    ok = np.isfinite(soc) & np.isfinite(pb) & np.asarray(eng_on, bool)
    if np.any(np.isfinite(p_whl)):
        dp = np.abs(np.gradient(np.where(np.isfinite(p_whl), p_whl, 0.0), dt))
        ok &= np.isfinite(p_whl) & (p_whl > 0) & (dp < 5000.0)
    win = {"soc_min": float(np.nanmin(soc)) if np.any(np.isfinite(soc)) else None,
           "soc_max": float(np.nanmax(soc)) if np.any(np.isfinite(soc)) else None,
           "soc_mean": float(np.nanmean(soc)) if np.any(np.isfinite(soc)) else None}
    if ok.sum() < min_points:
        return {"fitted": False, "why": f"only {int(ok.sum())} steady engine-on steps with SOC and "
                "battery power", **win}
    x, y = soc[ok], pb[ok]
    if np.ptp(x) < 0.01:
        return {"fitted": False, "why": f"SOC spans only {np.ptp(x):.3f} during engine-on "
                "propulsion: the slope is not identifiable", **win}
    xm = float(np.mean(x))
    scale = max(float(np.std(y)), 100.0)
    from scipy.optimize import least_squares

    res = least_squares(lambda c: (c[0] * (x - xm) + c[1] - y) / scale, x0=[0.0, float(np.median(y))],
                        loss="soft_l1")
    slope, c0 = float(res.x[0]), float(res.x[1])
    intercept = c0 - slope * xm
    pred = slope * x + intercept
    ss_res = float(np.sum((y - pred) ** 2))
    ss_tot = float(np.sum((y - np.mean(y)) ** 2))
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan")
    edges = np.linspace(np.min(x), np.max(x), 11)
    idx = np.clip(np.digitize(x, edges) - 1, 0, 9)
    bins = [{"soc": float(0.5 * (edges[i] + edges[i + 1])), "ess_pwr_median_w": float(np.median(y[idx == i])),
             "n": int(np.sum(idx == i))} for i in range(10) if np.any(idx == i)]
    out: dict[str, Any] = {"fitted": True, "slope_w": slope, "intercept_w": intercept, "r2": r2, "n": int(ok.sum()),
           "bins": bins, **win}
    if slope > 0:
        out["soc_gain_w"] = slope
        out["soc_target"] = -intercept / slope
    else:
        out["why"] = "battery power does not rise with SOC: no SOC regulation visible"
    return out
