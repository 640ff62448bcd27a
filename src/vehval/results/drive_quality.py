"""Drive quality per SAE J2951 (2011): how closely the driver followed the speed trace.

For the driven trace (D) and the reference trace (T) on the same samples, each interval i
between samples has mean speed v = (v_i + v_i+1)/2, acceleration a = (v_i+1 - v_i)/dt and
distance d = v dt. With the road load F_RL = A + B v + C v^2 and the inertia force
F_I = 1.015 m a (J2951's equivalent inertia mass, rotating parts 1.5 %):

* CE  = sum of max(F_RL + F_I, 0) d   cycle energy (positive tractive work) [J]
* IWT = sum of max(F_I, 0) d          inertial work [J]
* ASC = sum of |a| dt                 absolute speed change [m/s]
* D   = sum of d                      distance [m]

and the ratings, in percent of the reference: ER = CE_D/CE_T - 1, DR = D_D/D_T - 1,
EER = 1 - (1 + DR)/(1 + ER), ASCR = ASC_D/ASC_T - 1, IWR = IWT_D/IWT_T - 1;
RMSSE = sqrt(mean((v_D - v_T)^2)) [m/s]. IWR, DR, ASCR and RMSSE do not need the test mass
or road load; ER and EER do.

Trace violations follow 40 CFR 86.115-78(c): the driven speed must stay within 2 mph above
the highest and below the lowest reference speed within +-1 s of each instant.
The tolerances checked are those EPA applies to J2951 (40 CFR 1066.425(j)): IWR within
-2.0 % to +4.0 % and RMSSE at most 0.8 mph, per phase.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from vehval.constants import MPH_M_PER_S

__all__ = [
    "IWR_TOLERANCE_PCT",
    "RMSSE_TOLERANCE_MPS",
    "ROTATING_MASS_FACTOR",
    "WINDOW_SPEED_MPS",
    "WINDOW_TIME_S",
    "DriveQuality",
    "drive_quality",
]

#: Equivalent inertia mass factor of SAE J2951 (test mass x 1.015) [-].
ROTATING_MASS_FACTOR = 1.015
#: Tolerances (40 CFR 1066.425(j)): IWR band [%], RMSSE limit [m/s] (0.8 mph).
IWR_TOLERANCE_PCT = (-2.0, 4.0)
RMSSE_TOLERANCE_MPS = 0.8 * MPH_M_PER_S
#: Speed-trace window of 40 CFR 86.115-78(c): +-2 mph, +-1 s.
WINDOW_SPEED_MPS = 2.0 * MPH_M_PER_S
WINDOW_TIME_S = 1.0


@dataclass
class DriveQuality:
    """J2951 metrics of one phase. Ratings in percent, RMSSE in m/s, None when undefined."""

    er_pct: float | None
    dr_pct: float | None
    eer_pct: float | None
    ascr_pct: float | None
    iwr_pct: float | None
    rmsse_mps: float | None
    violations: int
    violation_s: float
    samples: int
    within_tolerance: bool | None

    def to_dict(self) -> dict[str, Any]:
        d = {k: (None if v is None else (round(v, 4) if isinstance(v, float) else v))
             for k, v in self.__dict__.items()}
        d["rmsse_mph"] = None if self.rmsse_mps is None else round(self.rmsse_mps / MPH_M_PER_S, 4)
        return d


def _works(t: np.ndarray, v: np.ndarray, mass_kg: float | None,
           road: tuple[float, float, float] | None) -> dict[str, float]:
    dt = np.diff(t)
    vm = 0.5 * (v[1:] + v[:-1])
    a = np.diff(v) / dt
    d = vm * dt
    keep = np.isfinite(d) & np.isfinite(a)
    out = {"D": float(d[keep].sum()), "ASC": float(np.abs(a * dt)[keep].sum())}
    m = (mass_kg or 1.0) * ROTATING_MASS_FACTOR
    fi = m * a
    out["IWT"] = float((np.maximum(fi, 0.0) * d)[keep].sum())
    if mass_kg and road is not None:
        A, B, C = road
        f = A + B * vm + C * vm * vm + fi
        out["CE"] = float((np.maximum(f, 0.0) * d)[keep].sum())
    return out


def _ratio_pct(a: float | None, b: float | None) -> float | None:
    if a is None or b is None or b == 0:
        return None
    return (a / b - 1.0) * 100.0


def _violations(t: np.ndarray, vd: np.ndarray, vt: np.ndarray) -> tuple[int, float]:
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    half = max(1, round(WINDOW_TIME_S / dt))
    size = 2 * half + 1
    hi = maximum_filter1d(vt, size, mode="nearest") + WINDOW_SPEED_MPS
    lo = minimum_filter1d(vt, size, mode="nearest") - WINDOW_SPEED_MPS
    bad = (vd > hi) | (vd < lo)
    if not bad.any():
        return 0, 0.0
    events = int(np.sum(np.diff(bad.astype(np.int8), prepend=0) == 1))
    return events, float(bad.sum() * dt)


def drive_quality(time_s: np.ndarray, driven_mps: np.ndarray, reference_mps: np.ndarray, *,
                  mass_kg: float | None = None,
                  road_load: tuple[float, float, float] | None = None,
                  segments: list[tuple[float, float]] | None = None) -> DriveQuality | None:
    """SAE J2951 metrics of a driven trace against its reference.

    Parameters
    ----------
    time_s : array
        Sample times [s] (10 Hz in J2951).
    driven_mps, reference_mps : array
        Driven and reference speed at ``time_s`` [m/s]; NaN samples are left out.
    mass_kg : float, optional
        Test mass [kg]; needed, with ``road_load``, for ER and EER.
    road_load : (A, B, C), optional
        Road-load coefficients [N], [N/(m/s)], [N/(m/s)^2].
    segments : list of (start, end), optional
        Record-time intervals [s] to evaluate (each one separately, then summed).

    Returns
    -------
    DriveQuality or None
        None when fewer than 10 common samples exist.
    """
    t = np.asarray(time_s, float)
    vd, vt = np.asarray(driven_mps, float), np.asarray(reference_mps, float)
    segs = segments or [(float(t[0]), float(t[-1]))] if t.size else []
    tot_d: dict[str, float] = {}
    tot_t: dict[str, float] = {}
    sq, n, events, vio_s = 0.0, 0, 0, 0.0
    for a, b in segs:
        m = (t >= a) & (t <= b) & np.isfinite(vd) & np.isfinite(vt)
        if m.sum() < 3:
            continue
        ts, ds, rs = t[m], vd[m], vt[m]
        for tot, v in ((tot_d, ds), (tot_t, rs)):
            for k, x in _works(ts, v, mass_kg, road_load).items():
                tot[k] = tot.get(k, 0.0) + x
        sq += float(np.sum((ds - rs) ** 2))
        n += int(m.sum())
        e, s = _violations(ts, ds, rs)
        events += e
        vio_s += s
    if n < 10:
        return None
    er = _ratio_pct(tot_d.get("CE"), tot_t.get("CE"))
    dr = _ratio_pct(tot_d["D"], tot_t["D"])
    eer = None
    if er is not None and dr is not None and er != -100.0:
        eer = (1.0 - (1.0 + dr / 100.0) / (1.0 + er / 100.0)) * 100.0
    iwr = _ratio_pct(tot_d["IWT"], tot_t["IWT"])
    rmsse = float(np.sqrt(sq / n))
    within = None
    if iwr is not None:
        within = bool(IWR_TOLERANCE_PCT[0] <= iwr <= IWR_TOLERANCE_PCT[1]
                      and rmsse <= RMSSE_TOLERANCE_MPS)
    return DriveQuality(er_pct=er, dr_pct=dr, eer_pct=eer,
                        ascr_pct=_ratio_pct(tot_d["ASC"], tot_t["ASC"]), iwr_pct=iwr,
                        rmsse_mps=rmsse, violations=events, violation_s=vio_s, samples=n,
                        within_tolerance=within)
