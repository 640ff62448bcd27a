"""Drive quality per SAE J2951 (JAN2014): how closely the driver followed the speed trace.

The computation, step by step, as the standard lays it out (SAE J2951 JAN2014, section 4
"data", section 5 "calculations"; the clause numbers below are those of that issue as
reproduced in EPA's adoption, 40 CFR 1066.425(j), which applies J2951 with its own
tolerances; where a detail could not be confirmed against the standard's text it is said
so, here and in docs/results.md):

1. Sampling (J2951 §4): both traces at 10 Hz. The driven speed is resampled onto a 10 Hz
   grid (linear interpolation; data faster than 10 Hz are first averaged over each 0.1 s
   interval), the reference (a 1 Hz schedule) is linearly interpolated onto the same grid.
   No further filtering of the driven speed: none is prescribed that could be confirmed,
   and a filter would change IWR (see the sensitivity figure ``iwr_1hz_pct`` below).
2. Per interval i between grid points (J2951 §5): mean speed v = (v_i + v_i+1)/2,
   acceleration a = (v_i+1 - v_i)/dt, distance d = v dt.
3. Forces (J2951 §5): road load F_RL = A + B v + C v^2 with the *target* coefficients,
   inertial force F_I = M a with M = 1.015 x ETW (equivalent test weight; the 1.5 %
   allowance for rotating parts is J2951's as the project reads it, not confirmed against
   the text; IWR, DR, ASCR and RMSSE do not depend on M).
4. Sums over the phase: CE = sum max(F_RL + F_I, 0) d (cycle energy) [J], IWT = sum
   max(F_I, 0) d (inertial work) [J], ASC = sum |a| dt [m/s], D = sum d [m].
5. Ratings (J2951 §5), in percent of the reference: ER = CE_D/CE_T - 1, DR = D_D/D_T - 1,
   EER = 1 - (1 + DR)/(1 + ER), ASCR = ASC_D/ASC_T - 1, IWR = IWT_D/IWT_T - 1;
   RMSSE = sqrt(mean((v_D - v_T)^2)) over the grid [m/s].
6. Tolerances (40 CFR 1066.425(j)): IWR within -2.0 % to +4.0 % and RMSSE at most 0.8 mph,
   per phase. EPA sets them for its own cycles; on other cycles (NEDC, WLTC) the check is
   reported for information.

Two figures explain a result without changing it: ``iwr_1hz_pct``, IWR from the same
traces sampled at 1 Hz (the schedule's own rate: speed noise and sub-second corrections
add positive inertial work at 10 Hz that 1 Hz does not see), and
``iwt_target_cruise_pct``, the driven positive inertial work where the reference holds a
constant speed, in percent of the reference IWT (corrections while cruising, which a
modal cycle such as the NEDC rewards with a large IWR).

Trace violations follow 40 CFR 86.115-78(c): the driven speed must stay within 2 mph above
the highest and below the lowest reference speed within +-1 s of each instant.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vehval.constants import MPH_M_PER_S

__all__ = [
    "IWR_TOLERANCE_PCT",
    "RATE_HZ",
    "RMSSE_TOLERANCE_MPS",
    "ROTATING_MASS_FACTOR",
    "WINDOW_SPEED_MPS",
    "WINDOW_TIME_S",
    "DriveQuality",
    "drive_quality",
    "iwr_reading",
    "on_grid",
]

#: Equivalent inertia mass factor of SAE J2951 (ETW x 1.015) [-] (step 3).
ROTATING_MASS_FACTOR = 1.015
#: Sample rate of the J2951 computation [Hz] (step 1).
RATE_HZ = 10.0
#: Tolerances (40 CFR 1066.425(j)): IWR band [%], RMSSE limit [m/s] (0.8 mph).
IWR_TOLERANCE_PCT = (-2.0, 4.0)
RMSSE_TOLERANCE_MPS = 0.8 * MPH_M_PER_S
#: Speed-trace window of 40 CFR 86.115-78(c): +-2 mph, +-1 s.
WINDOW_SPEED_MPS = 2.0 * MPH_M_PER_S
WINDOW_TIME_S = 1.0


@dataclass
class DriveQuality:
    """J2951 metrics of one phase. Ratings in percent, RMSSE in m/s, None when undefined.

    ``samples`` counts the 10 Hz grid points; ``iwr_1hz_pct`` and ``iwt_target_cruise_pct``
    explain IWR (module docstring) and take no part in ``within_tolerance``.
    """

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
    iwr_1hz_pct: float | None = None
    iwt_target_cruise_pct: float | None = None

    def to_dict(self) -> dict[str, Any]:
        d = {k: (None if v is None else (round(v, 4) if isinstance(v, float) else v))
             for k, v in self.__dict__.items()}
        d["rmsse_mph"] = None if self.rmsse_mps is None else round(self.rmsse_mps / MPH_M_PER_S, 4)
        return d


def iwr_reading(dq: DriveQuality) -> str:
    """What an IWR outside the tolerance band is made of, in one clause ("" when IWR is
    inside or undefined): IWR of the same traces at 1 Hz, and the driven inertial work where
    the reference cruises in percent of the reference's (module docstring).

    Inside the band at 1 Hz, the excess is speed content above 1 Hz (speed-sensor noise or
    sub-second corrections); still outside, the driver added inertial work at 1 Hz too.
    """
    lo, hi = IWR_TOLERANCE_PCT
    if dq.iwr_pct is None or lo <= dq.iwr_pct <= hi or dq.iwr_1hz_pct is None:
        return ""
    slow = dq.iwr_1hz_pct
    text = (f"IWR at 1 Hz {slow:+.2f} %, "
            + ("inside the band: the excess is speed content above 1 Hz (speed-sensor noise "
               "or sub-second corrections)" if lo <= slow <= hi else
               "also outside the band: the driver's speed changes, not only speed noise"))
    if dq.iwt_target_cruise_pct is not None:
        text += (f"; corrections where the reference cruises add {dq.iwt_target_cruise_pct:.1f} % "
                 "of the reference's inertial work")
    return text


def on_grid(t: np.ndarray, v: np.ndarray, rate_hz: float = RATE_HZ) -> tuple[np.ndarray, np.ndarray]:
    """``v`` on a uniform ``rate_hz`` grid from ``t[0]`` (J2951 step 1) [s], [m/s].

    Samples faster than the grid are averaged over each grid interval (centred on the grid
    point) before the linear interpolation; slower or equal ones are interpolated.
    """
    step = 1.0 / rate_hz
    grid = t[0] + step * np.arange(int(np.floor((t[-1] - t[0]) / step + 1e-9)) + 1)
    period = float(np.median(np.diff(t))) if t.size > 1 else step
    if period < 0.75 * step:
        c = np.concatenate([[0.0], np.cumsum(v)])
        lo = np.searchsorted(t, grid - 0.5 * step, side="left")
        hi = np.searchsorted(t, grid + 0.5 * step, side="left")
        n = hi - lo
        mean = np.where(n > 0, (c[hi] - c[lo]) / np.maximum(n, 1), np.nan)
        ok = np.isfinite(mean)
        return grid[ok], mean[ok]
    return grid, np.interp(grid, t, v)


def _works(t: np.ndarray, v: np.ndarray, mass_kg: float | None,
           road: tuple[float, float, float] | None,
           cruise: np.ndarray | None = None) -> dict[str, float]:
    """Sums of J2951 step 4 over one trace (steps 2-3 per interval)."""
    dt = np.diff(t)
    vm = 0.5 * (v[1:] + v[:-1])
    a = np.diff(v) / dt
    d = vm * dt
    keep = np.isfinite(d) & np.isfinite(a)
    out = {"D": float(d[keep].sum()), "ASC": float(np.abs(a * dt)[keep].sum())}
    m = (mass_kg or 1.0) * ROTATING_MASS_FACTOR
    fi = m * a
    wi = np.maximum(fi, 0.0) * d
    out["IWT"] = float(wi[keep].sum())
    if cruise is not None:
        out["IWT_cruise"] = float(wi[keep & cruise].sum())
    if mass_kg and road is not None:
        A, B, C = road
        f = A + B * vm + C * vm * vm + fi
        out["CE"] = float((np.maximum(f, 0.0) * d)[keep].sum())
    return out


def _ratio_pct(a: float | None, b: float | None) -> float | None:
    if a is None or b is None or b == 0:
        return None
    return (a / b - 1.0) * 100.0


def _window_extremes(v: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray]:
    """Highest and lowest of ``v`` over ``[i - half, i + half]`` at every ``i``, the end
    samples repeated beyond the ends (scipy.ndimage's ``maximum_filter1d`` and
    ``minimum_filter1d`` with ``mode="nearest"``, without importing scipy: 0.3 s)."""
    windows = np.lib.stride_tricks.sliding_window_view(np.pad(v, half, mode="edge"), 2 * half + 1)
    return windows.max(axis=1), windows.min(axis=1)


def _violations(t: np.ndarray, vd: np.ndarray, vt: np.ndarray) -> tuple[int, float]:
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    half = max(1, round(WINDOW_TIME_S / dt))
    vmax, vmin = _window_extremes(vt, half)
    hi = vmax + WINDOW_SPEED_MPS
    lo = vmin - WINDOW_SPEED_MPS
    bad = (vd > hi) | (vd < lo)
    if not bad.any():
        return 0, 0.0
    events = int(np.sum(np.diff(bad.astype(np.int8), prepend=0) == 1))
    return events, float(bad.sum() * dt)


def drive_quality(time_s: np.ndarray, driven_mps: np.ndarray, reference_mps: np.ndarray, *,
                  mass_kg: float | None = None,
                  road_load: tuple[float, float, float] | None = None,
                  segments: list[tuple[float, float]] | None = None) -> DriveQuality | None:
    """SAE J2951 metrics of a driven trace against its reference (module docstring).

    Parameters
    ----------
    time_s : array
        Sample times [s] (any rate: the computation resamples to 10 Hz).
    driven_mps, reference_mps : array
        Driven and reference speed at ``time_s`` [m/s]; NaN samples are left out.
    mass_kg : float, optional
        Equivalent test weight ETW [kg]; needed, with ``road_load``, for ER and EER.
    road_load : (A, B, C), optional
        Target road-load coefficients [N], [N/(m/s)], [N/(m/s)^2].
    segments : list of (start, end), optional
        Record-time intervals [s] to evaluate (each one separately, then summed).

    Returns
    -------
    DriveQuality or None
        None when fewer than 10 common grid points exist.
    """
    t = np.asarray(time_s, float)
    vd, vt = np.asarray(driven_mps, float), np.asarray(reference_mps, float)
    segs = segments or [(float(t[0]), float(t[-1]))] if t.size else []
    tot: dict[str, dict[str, float]] = {"D": {}, "T": {}, "D1": {}, "T1": {}}
    sq, n, events, vio_s = 0.0, 0, 0, 0.0
    for a, b in segs:
        m = (t >= a) & (t <= b) & np.isfinite(vd) & np.isfinite(vt)
        if m.sum() < 3:
            continue
        gd_t, ds = on_grid(t[m], vd[m])
        ts, rs = on_grid(t[m], vt[m])
        if ts.size != gd_t.size:            # averaging dropped empty intervals: common points
            keep = np.isin(ts, gd_t)
            ts, rs = ts[keep], rs[keep]
            ds = ds[np.isin(gd_t, ts)]
        if ts.size < 3:
            continue
        cruise = np.diff(rs) == 0
        for key, v, cr in (("D", ds, cruise), ("T", rs, None)):
            for k, x in _works(ts, v, mass_kg, road_load, cr).items():
                tot[key][k] = tot[key].get(k, 0.0) + x
        t1 = ts[::round(RATE_HZ)]
        if t1.size >= 3:                  # the same traces at 1 Hz (sensitivity figure)
            for key, v in (("D1", ds), ("T1", rs)):
                x = _works(t1, v[::round(RATE_HZ)], mass_kg, None)["IWT"]
                tot[key]["IWT"] = tot[key].get("IWT", 0.0) + x
        sq += float(np.sum((ds - rs) ** 2))
        n += int(ts.size)
        e, s = _violations(ts, ds, rs)
        events += e
        vio_s += s
    if n < 10:
        return None
    td, tt = tot["D"], tot["T"]
    er = _ratio_pct(td.get("CE"), tt.get("CE"))
    dr = _ratio_pct(td["D"], tt["D"])
    eer = None
    if er is not None and dr is not None and er != -100.0:
        eer = (1.0 - (1.0 + dr / 100.0) / (1.0 + er / 100.0)) * 100.0
    iwr = _ratio_pct(td["IWT"], tt["IWT"])
    rmsse = float(np.sqrt(sq / n))
    within = None
    if iwr is not None:
        within = bool(IWR_TOLERANCE_PCT[0] <= iwr <= IWR_TOLERANCE_PCT[1]
                      and rmsse <= RMSSE_TOLERANCE_MPS)
    cruise_pct = (100.0 * td["IWT_cruise"] / tt["IWT"]) if tt["IWT"] > 0 else None
    return DriveQuality(er_pct=er, dr_pct=dr, eer_pct=eer,
                        ascr_pct=_ratio_pct(td["ASC"], tt["ASC"]), iwr_pct=iwr,
                        rmsse_mps=rmsse, violations=events, violation_s=vio_s, samples=n,
                        within_tolerance=within,
                        iwr_1hz_pct=_ratio_pct(tot["D1"].get("IWT"), tot["T1"].get("IWT")),
                        iwt_target_cruise_pct=cruise_pct)
