"""Gearbox and converter from engine-to-wheel speed ratios: gears, lock-up, shifts.

With the converter locked the engine turns at ``ratio_i · ω_wheel``: the ratio
``ω_eng / ω_wheel`` of moving samples clusters at the overall ratios (gearbox x final drive).
Clusters are the peaks of a histogram of ``log(ratio)`` (0.5 % bins, smoothed); a peak is
a gear when it holds at least ``MIN_SHARE`` of the samples and stands 8 % apart from a
stronger one; its ratio is the median of the samples within ±1.5 % of the peak.
Samples within ±2 % of a gear are *locked* in it; samples between two gears are that
gear's converter slip (the engine turns faster than the turbine). Only sharp clusters
(relative inter-quartile range below 1.2 %) are gears: slip makes broad humps.

A first gear in which the converter never locks leaves no cluster, only launches whose
ratio lies well above the lowest locked gear (more than 25 % above it, in more than 1 % of
the moving samples). Its ratio is then the most frequent launch ratio (median): converter
slip is in it, so it is an upper bound, flagged ``locked_in_data: false``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vehval.identify.traces import IdentificationError, Trace, smooth

MIN_SPEED_MPS = 1.5      # [m/s] ratio only defined when moving
MIN_SHARE = 0.004        # [-] smallest share of moving samples a gear cluster may hold
LOCK_TOL = 0.02          # [-] relative band around a gear ratio counted as locked
PEAK_SEP = 0.08          # [-] minimum relative distance between two gear ratios
SHARP_IQR = 0.012        # [-] a gear cluster is narrower than this (relative IQR)
MIN_DWELL_S = 1.0        # [s] a gear held shorter than this is a transient, not a shift


@dataclass
class GearFit:
    """Overall ratios (first gear first) and how well the data support each."""

    ratios: np.ndarray
    samples: list[int]
    spread: list[float]          # relative IQR of the locked samples around each ratio
    locked_in_data: list[bool]

    def to_dict(self) -> dict:
        return {"ratios": [float(r) for r in self.ratios], "samples": self.samples,
                "relative_iqr": self.spread, "locked_in_data": self.locked_in_data}


def speed_ratio(tr: Trace, wheel_radius_m: float) -> np.ndarray:
    """Engine-to-wheel speed ratio [-] (NaN when too slow to define one)."""
    out = np.full_like(tr.v, np.nan)
    m = tr.v > MIN_SPEED_MPS
    out[m] = tr.w_eng[m] * wheel_radius_m / tr.v[m]
    return out


def find_gears(traces: list[Trace], wheel_radius_m: float) -> GearFit:
    """Gear ratios from the clusters of the engine-to-wheel speed ratio of ``traces``."""
    r = np.concatenate([speed_ratio(t, wheel_radius_m) for t in traces])
    r = r[np.isfinite(r) & (r > 0.3) & (r < 40)]
    if r.size < 200:
        raise IdentificationError("gears: fewer than 200 moving samples with engine speed; "
                                  "give longer driven tests")
    lr = np.log(r)
    bins = np.arange(lr.min(), lr.max() + 0.005, 0.005)
    h, edges = np.histogram(lr, bins=bins)
    hs = smooth(h.astype(float), 3)
    centres = 0.5 * (edges[1:] + edges[:-1])
    order = np.argsort(hs)[::-1]
    peaks: list[float] = []
    for i in order:
        if hs[i] * 3 < MIN_SHARE * r.size:   # 3 bins = 1.5 % band
            break
        c = centres[i]
        if all(abs(c - p) > np.log(1 + PEAK_SEP) for p in peaks):
            peaks.append(c)
    if not peaks:
        raise IdentificationError("gears: no engine-to-wheel speed ratio cluster found "
                                  "(is the engine speed channel right?)")
    ratios, counts, spread = [], [], []
    for p in sorted(peaks, reverse=True):
        near = r[np.abs(lr - p) < np.log(1.015)]
        med = float(np.median(near))
        band = r[np.abs(r / med - 1) < LOCK_TOL]
        q1, q3 = np.percentile(band, [25, 75])
        if (q3 - q1) / med < SHARP_IQR:
            ratios.append(med)
            counts.append(int(band.size))
            spread.append(float((q3 - q1) / med))
    if not ratios:
        raise IdentificationError("gears: no sharp engine-to-wheel speed ratio cluster "
                                  "(the converter never locks?): cannot identify the gears")
    locked = [True] * len(ratios)
    launch = r[r > 1.25 * ratios[0]]
    if launch.size > 0.01 * r.size:
        ratios.insert(0, float(np.median(launch)))
        counts.insert(0, int(launch.size))
        q1, q3 = np.percentile(launch, [25, 75])
        spread.insert(0, float((q3 - q1) / ratios[0]))
        locked.insert(0, False)
    return GearFit(ratios=np.asarray(ratios), samples=counts, spread=spread,
                   locked_in_data=locked)


def assign_gears(tr: Trace, ratios: np.ndarray, wheel_radius_m: float,
                 locked_first: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Gear (1-based; 0 standing) and locked flag of every sample.

    Locked within ±2 % of a gear; otherwise the highest gear whose ratio is below the
    measured one (converter slip raises the engine speed); below ``MIN_SPEED_MPS`` the
    first gear. Gears held shorter than ``MIN_DWELL_S`` take the previous gear.
    """
    rr = speed_ratio(tr, wheel_radius_m)
    gear = np.zeros(tr.v.size, dtype=int)
    locked = np.zeros(tr.v.size, dtype=bool)
    ok = np.isfinite(rr)
    rel = rr[ok, None] / ratios[None, :] - 1.0
    near = np.abs(rel) < LOCK_TOL
    if not locked_first:
        near[:, 0] = False
    g_lock = np.argmax(near, axis=1)
    edges = ratios * (1 + LOCK_TOL)
    if len(ratios) > 1 and not locked_first:
        edges = edges.copy()
        edges[0] = 1.25 * ratios[1]  # launches in an unlocked first gear (see find_gears)
    below = np.sum(edges[None, :] < rr[ok, None], axis=1)  # gears slower than the sample
    g_slip = np.clip(len(ratios) - below + 1, 1, len(ratios))
    g = np.where(near.any(axis=1), g_lock + 1, g_slip)
    gear[ok] = g
    locked[ok] = near.any(axis=1)
    gear[~ok & (tr.v > 0.05)] = 1
    # open converter without drive (coasting, braking): the engine idles and the ratio says
    # nothing about the gear; hold the last gear seen with the converter locked or pulling
    hold = ok & ~locked & (tr.force <= 0)
    last = 0
    for i in range(gear.size):
        if hold[i] and last:
            gear[i] = last
        elif gear[i] > 0:
            last = gear[i]
        else:
            last = 0
    # remove short dwells (transients while the ratio sweeps across a gear during a shift)
    n_min = round(MIN_DWELL_S / tr.dt)
    i = 0
    while i < gear.size:
        j = i
        while j < gear.size and gear[j] == gear[i]:
            j += 1
        if gear[i] > 0 and j - i < n_min and i > 0:
            gear[i:j] = gear[i - 1]
        i = j
    return gear, locked


def lockup_speeds(traces, gears, locks, n_gears: int, v_cap: float) -> list[float]:
    """Per gear: the lower edge [m/s] of the lowest 1 m/s speed bin from which every faster
    bin (with >= 20 samples of that gear) is >= 70 % locked; ``v_cap`` when none is."""
    v = np.concatenate([t.v for t in traces])
    g = np.concatenate(gears)
    lk = np.concatenate(locks)
    out = []
    for k in range(1, n_gears + 1):
        m = g == k
        edges = np.arange(0.0, max(float(v[m].max(initial=0.0)), 1.0) + 1.0, 1.0)
        idx = np.digitize(v[m], edges) - 1
        cnt = np.bincount(idx, minlength=edges.size)
        loc = np.bincount(idx, weights=lk[m].astype(float), minlength=edges.size)
        good = [(c < 20) or (lc / c >= 0.7) for c, lc in zip(cnt, loc)]
        filled = [c >= 20 for c in cnt]
        found = v_cap
        for j in range(edges.size - 1, -1, -1):
            if not good[j]:
                break
            if filled[j]:
                found = float(edges[j])
        out.append(float(found) if np.count_nonzero(lk & m) >= 20 else float(v_cap))
    return out


def converter_capacity(traces, gears, locks, ratios, wheel_radius_m, efficiency,
                       lag_s: float) -> tuple[float, int]:
    """Coupling capacity k [N·m s²/rad²] of ``T = k ω_e (ω_e − ω_t)`` on open-converter
    samples with positive drive torque (median of T / (ω_e (ω_e − ω_t))), and the count."""
    ks = []
    for tr, g, lk in zip(traces, gears, locks):
        f = np.interp(tr.t + lag_s, tr.t, tr.force)
        m = (~lk) & (g > 0) & (f > 200) & (tr.v > MIN_SPEED_MPS)
        w_t = ratios[g[m] - 1] * tr.v[m] / wheel_radius_m
        slip = tr.w_eng[m] - w_t
        t_in = f[m] * wheel_radius_m / (ratios[g[m] - 1] * efficiency)
        ok = slip > 5.0
        ks.append(t_in[ok] / (tr.w_eng[m][ok] * slip[ok]))
    k = np.concatenate(ks) if ks else np.array([])
    if k.size < 20:
        return 0.02, int(k.size)
    return float(np.median(k)), int(k.size)


def shift_events(tr: Trace, gear: np.ndarray, p_max_w: float, lag_s: float,
                 locked: np.ndarray | None = None) -> list[tuple]:
    """(from gear, to gear, speed [m/s], load [0..1]) of every shift between two gears.

    With ``locked`` given, only shifts with the converter locked in the old gear within 2 s
    before and in the new gear within 2 s after count (a ratio sweeping across the gear
    bands while the engine idles is no shift).
    """
    f = np.interp(tr.t + lag_s, tr.t, tr.force)
    load = np.clip(smooth(f * tr.v, round(1.0 / tr.dt)) / p_max_w, 0.0, 1.0)
    ev = []
    idx = np.nonzero((gear[1:] != gear[:-1]) & (gear[1:] > 0) & (gear[:-1] > 0))[0]
    n2 = round(2.0 / tr.dt)
    for i in idx:
        if locked is not None:
            before = slice(max(i - n2, 0), i + 1)
            after = slice(i + 1, i + 1 + n2)
            if not (np.any(locked[before] & (gear[before] == gear[i]))
                    and np.any(locked[after] & (gear[after] == gear[i + 1]))):
                continue
        k = max(int(i) - round(0.5 / tr.dt), 0)   # load just before the shift
        ev.append((int(gear[i]), int(gear[i + 1]), float(tr.v[i]), float(load[k])))
    return ev


def shift_lines(events: list[tuple], ratios: np.ndarray, v_top: float, w_max: float,
                wheel_radius_m: float):
    """Up and down lines per gear pair: (speed at zero load, at full load) [m/s].

    Least squares of speed on load when a pair has >= 4 shifts over a load spread > 0.15,
    else the median speed (flat line). A pair with no shift observed gets the engine speed
    of the observed shifts (median, in the lower gear) turned into a vehicle speed.
    Downshift lines are kept at least 10 % below the upshift lines (hysteresis); no line
    asks the engine for more than 95 % of its maximum speed ``w_max`` [rad/s].
    """
    n = len(ratios) - 1
    lines = {}
    for kind, sel in (("up", lambda a, b: b == a + 1), ("down", lambda a, b: b == a - 1)):
        per_pair: list[list[tuple[float, float]]] = [[] for _ in range(n)]
        for a, b, v, ld in events:
            if sel(a, b):
                low = min(a, b)
                per_pair[low - 1].append((v, ld))
        eng_spd = [v * ratios[i] for i in range(n) for v, _ in per_pair[i]]
        w_ref = float(np.median(eng_spd)) if eng_spd else None
        z, f = [], []
        for i in range(n):
            pts = np.asarray(per_pair[i]) if per_pair[i] else np.zeros((0, 2))
            if len(pts) >= 4 and np.ptp(pts[:, 1]) > 0.15:
                b1, b0 = np.polyfit(pts[:, 1], pts[:, 0], 1)
                b1 = max(b1, 0.0)
                b0 = float(np.median(pts[:, 0] - b1 * pts[:, 1]))
            elif len(pts):
                b0, b1 = float(np.median(pts[:, 0])), 0.0
            elif w_ref is not None:
                b0, b1 = w_ref / ratios[i], 0.0
            else:
                b0, b1 = v_top * (i + 1) / (n + 1), 0.0
            cap = 0.95 * w_max * wheel_radius_m / ratios[i]
            z.append(float(min(b0, cap)))
            f.append(float(min(b0 + b1, cap)))
        lines[kind] = (z, f)
    uz, uf = lines["up"]
    dz, df = lines["down"]
    dz = [min(d, 0.9 * u) for d, u in zip(dz, uz)]
    df = [min(d, 0.9 * u) for d, u in zip(df, uf)]
    return uz, uf, dz, df
