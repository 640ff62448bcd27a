"""Regenerative / friction braking split as a function of deceleration and speed.

Total braking power at the wheels is the negative wheel power. When the friction brake
force is measured, friction power = force x speed (measured) and regenerative power is the
rest. Otherwise regenerative power is inferred from the battery: wheel-side regen power =
(battery charging power + auxiliary load) / path efficiency, and friction = total - regen
(inferred). The result says which of the two was used.
"""

from __future__ import annotations

import numpy as np


def braking_split(v: np.ndarray, a: np.ndarray, p_whl: np.ndarray, ess_pwr: np.ndarray,
                  brk_frc: np.ndarray, *, aux_w: float = 0.0, path_efficiency: float = 0.85,
                  min_brake_w: float = 500.0, min_speed_mps: float = 1.0) -> dict:
    """Regenerative share of braking energy, overall and binned by deceleration and speed.

    Parameters
    ----------
    v : ndarray [m/s]
    a : ndarray [m/s²]
    p_whl : ndarray [W] (< 0 braking)
    ess_pwr : ndarray [W] (< 0 charging)
    brk_frc : ndarray [N] (friction brake force, NaN when not measured)
    aux_w : float
        Auxiliary electrical load [W] carried by the battery during braking.
    path_efficiency : float
        Wheel-to-battery efficiency used when the regen power is inferred from the battery.
    min_brake_w, min_speed_mps : float
        Steps count as braking below ``-min_brake_w`` wheel power and above ``min_speed_mps``.

    Returns
    -------
    dict
    """
    brake = np.isfinite(p_whl) & (p_whl < -min_brake_w) & np.isfinite(v) & (v > min_speed_mps)
    if not brake.any():
        return {"why": "no braking steps with a known wheel power"}
    total = -p_whl
    if np.any(np.isfinite(brk_frc[brake])):
        fric = np.clip(np.where(np.isfinite(brk_frc), brk_frc, 0.0) * v, 0.0, None)
        regen = np.clip(total - fric, 0.0, None)
        basis = "friction measured (brake force x speed); regen = total - friction"
    elif np.any(np.isfinite(ess_pwr[brake])):
        regen = np.clip((-np.where(np.isfinite(ess_pwr), ess_pwr, 0.0) + aux_w) / path_efficiency, 0.0, None)
        regen = np.minimum(regen, total)
        fric = total - regen
        basis = (f"inferred: regen = (battery charging power + {aux_w:g} W auxiliary) / "
                 f"{path_efficiency:g} path efficiency; friction = total - regen")
    else:
        return {"why": "neither brake force nor battery power measured: the split is unknown"}
    share = np.where(total > 0, regen / np.where(total > 0, total, 1.0), np.nan)
    e_tot = float(np.sum(total[brake]))
    out = {"basis": basis, "steps": int(brake.sum()),
           "regen_energy_share": float(np.sum(regen[brake]) / e_tot) if e_tot > 0 else None}
    decel = -np.asarray(a, float)
    d_edges = np.array([0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 10.0])
    v_edges = np.array([0.0, 2.5, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0, 70.0])
    table = []
    for i in range(d_edges.size - 1):
        for j in range(v_edges.size - 1):
            sel = (brake & np.isfinite(decel) & (decel >= d_edges[i]) & (decel < d_edges[i + 1])
                   & (v >= v_edges[j]) & (v < v_edges[j + 1]))
            if sel.sum() >= 3:
                table.append({"decel_mps2": [float(d_edges[i]), float(d_edges[i + 1])],
                              "speed_mps": [float(v_edges[j]), float(v_edges[j + 1])],
                              "regen_share": float(np.sum(regen[sel]) / np.sum(total[sel])),
                              "n": int(sel.sum())})
    out["by_decel_speed"] = table
    out["regen_share_median"] = float(np.nanmedian(share[brake]))
    return out
