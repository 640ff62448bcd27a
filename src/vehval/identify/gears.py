"""Gearbox and converter from engine-to-wheel speed ratios: gears, lock-up, shifts.

With the converter locked the engine turns at ``ratio_i · ω_wheel``: the ratio
``ω_eng / ω_wheel`` of moving samples clusters at the overall ratios (gearbox x final drive).
Clusters are the peaks of a histogram of ``log(ratio)`` (0.5 % bins, smoothed), each 8 %
apart from a stronger one; its ratio is the median of the samples within ±1.5 % of the peak.
A peak is a gear when it is sharp (its samples within ±0.5 % at least ``MIN_CONTRAST``
times what the background 3-8 % away would put there) and holds at least ``MIN_SHARE`` of
the samples; a sharp peak holding fewer is a gear seen briefly, used when a declared gear
count asks for it and reported otherwise.
Samples within ±2 % of a gear are *locked* in it; samples between two gears are that
gear's converter slip (the engine turns faster than the turbine): slip makes broad humps.

A first gear in which the converter never locks leaves no cluster, only launches whose
ratio lies well above the lowest locked gear (more than 25 % above it, in more than 1 % of
the moving samples). Its ratio is then the most frequent launch ratio (median): converter
slip is in it, so it is an upper bound, flagged ``locked_in_data: false``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vehval.identify.traces import IdentificationError, Trace, smooth

MIN_SPEED_MPS = 1.5      # [m/s] ratio only defined when moving
MIN_SHARE = 0.004        # [-] smallest share of moving samples a gear cluster may hold
LOCK_TOL = 0.02          # [-] relative band around a gear ratio counted as locked
PEAK_SEP = 0.08          # [-] minimum relative distance between two gear ratios
SHARP_IQR_MAX = 0.016    # [-] a gear cluster is narrower than this (relative IQR, ±2 % band)
MIN_CONTRAST = 4.0       # [-] core samples over a flat background's share (see _candidates)
MIN_CORE = 20            # [-] samples a candidate peak needs within its 1.5 % band
MIN_DWELL_S = 1.0        # [s] a gear held shorter than this is a transient, not a shift


@dataclass
class GearFit:
    """Overall ratios (first gear first) and how well the data support each."""

    ratios: np.ndarray
    samples: list[int]
    spread: list[float]          # relative IQR of the locked samples around each ratio
    locked_in_data: list[bool]
    declared: int | None = None   # gear count declared (spec or --gears)
    notes: list[str] = field(default_factory=list)  # gears seen briefly or not at all

    def to_dict(self) -> dict:
        return {"ratios": [float(r) for r in self.ratios], "samples": self.samples,
                "relative_iqr": self.spread, "locked_in_data": self.locked_in_data,
                "declared": self.declared, "notes": self.notes}


def speed_ratio(tr: Trace, wheel_radius_m: float) -> np.ndarray:
    """Engine-to-wheel speed ratio [-] (NaN when too slow to define one)."""
    out = np.full_like(tr.v, np.nan)
    m = tr.v > MIN_SPEED_MPS
    out[m] = tr.w_eng[m] * wheel_radius_m / tr.v[m]
    return out


def _candidates(r: np.ndarray) -> list[dict]:
    """Sharp clusters of the ratio samples ``r``: peaks of the smoothed log histogram, each
    with its median ratio, the samples within ±0.5 % (``core``) and ±2 % (``band``), and its
    contrast (core samples over those a flat background would put there, the background
    counted 3-8 % away)."""
    lr = np.log(r)
    bins = np.arange(lr.min(), lr.max() + 0.005, 0.005)
    h, edges = np.histogram(lr, bins=bins)
    hs = smooth(h.astype(float), 3)
    centres = 0.5 * (edges[1:] + edges[:-1])
    out: list[dict] = []
    for i in np.argsort(hs)[::-1]:
        if hs[i] * 3 < MIN_CORE:
            break
        c = centres[i]
        if any(abs(c - np.log(d["ratio"])) <= np.log(1 + PEAK_SEP) for d in out):
            continue
        med = float(np.median(r[np.abs(lr - c) < np.log(1.015)]))
        rel = np.abs(r / med - 1)
        core, band = int(np.count_nonzero(rel < 0.005)), r[rel < LOCK_TOL]
        bg = np.count_nonzero((rel > 0.03) & (rel < 0.08)) / 10.0
        q1, q3 = np.percentile(band, [25, 75])
        out.append({"ratio": med, "core": core, "band": int(band.size),
                    "share": band.size / r.size, "iqr": float((q3 - q1) / med),
                    "contrast": core / max(bg, 1.0)})
    return out


def _is_gear(c: dict) -> bool:
    return c["contrast"] >= MIN_CONTRAST and c["iqr"] < SHARP_IQR_MAX


def find_gears(traces: list[Trace], wheel_radius_m: float,
               declared: int | None = None) -> GearFit:
    """Gear ratios from the clusters of the engine-to-wheel speed ratio of ``traces``.

    A sharp cluster (contrast >= ``MIN_CONTRAST`` over the local background) holding at least
    ``MIN_SHARE`` of the samples is a gear; a sharp one holding fewer is a gear *seen briefly*:
    used when a ``declared`` gear count asks for it, else reported in ``notes``. With a
    declared count the data contradict (more sharp clusters than gears) the call fails.
    """
    r = np.concatenate([speed_ratio(t, wheel_radius_m) for t in traces])
    r = r[np.isfinite(r) & (r > 0.3) & (r < 40)]
    if r.size < 200:
        raise IdentificationError("gears: fewer than 200 moving samples with engine speed; "
                                  "give longer driven tests")
    cands = [c for c in _candidates(r) if _is_gear(c)]
    if not cands:
        raise IdentificationError("gears: no sharp engine-to-wheel speed ratio cluster "
                                  "(the converter never locks?): cannot identify the gears")
    strong = [c for c in cands if c["share"] >= MIN_SHARE]
    brief = [c for c in cands if c["share"] < MIN_SHARE]
    notes: list[str] = []
    chosen = list(strong)
    launch = r[r > 1.25 * max(c["ratio"] for c in chosen)]
    has_launch = launch.size > 0.01 * r.size
    if declared is not None:
        if len(strong) > declared:
            raise IdentificationError(
                f"gears: {declared} gears declared, but the data show {len(strong)} locked "
                f"gear ratios ({', '.join(format(c['ratio'], '.3f') for c in sorted(strong, key=lambda c: -c['ratio']))}); "
                "check --gears (or the spec's gears)")
        for c in sorted(brief, key=lambda c: -c["contrast"]):
            if len(chosen) + has_launch >= declared:
                break
            chosen.append(c)
            notes.append(f"ratio {c['ratio']:.3f} seen briefly ({c['band']} samples, contrast "
                         f"{c['contrast']:.0f}): used as a gear, {declared} gears declared")
        launch = r[r > 1.25 * max(c["ratio"] for c in chosen)]
        has_launch = launch.size > 0.01 * r.size and len(chosen) < declared
        if launch.size > 0.01 * r.size and not has_launch:
            notes.append(f"launches at ratio {float(np.median(launch)):.3f} "
                         f"({100 * launch.size / r.size:.1f} % of the moving samples, above the "
                         "first locked gear): taken as converter slip in first gear, not as a "
                         f"gear of its own, {declared} gears declared")
    else:
        notes += [f"ratio {c['ratio']:.3f} seen briefly ({c['band']} samples, "
                  f"{100 * c['share']:.2f} % of the moving samples, contrast "
                  f"{c['contrast']:.0f}): not used; declare the gear count (--gears) to use it"
                  for c in brief]
    chosen.sort(key=lambda c: -c["ratio"])
    ratios = [c["ratio"] for c in chosen]
    counts = [c["band"] for c in chosen]
    spread = [c["iqr"] for c in chosen]
    locked = [True] * len(ratios)
    if has_launch:
        ratios.insert(0, float(np.median(launch)))
        counts.insert(0, int(launch.size))
        q1, q3 = np.percentile(launch, [25, 75])
        spread.insert(0, float((q3 - q1) / ratios[0]))
        locked.insert(0, False)
    lr_ = [x for x, lk in zip(ratios, locked) if lk]
    steps = np.asarray(lr_[:-1]) / np.asarray(lr_[1:])
    if steps.size >= 2:
        typical = float(np.median(steps))
        for k in np.nonzero(steps > 1.3 * typical)[0]:
            notes.append(f"step {lr_[k]:.3f} -> {lr_[k + 1]:.3f} is {steps[k]:.2f}, "
                         f"against {typical:.2f} elsewhere: a gear between them may not be "
                         "seen locked in these tests")
    if declared is not None and len(ratios) < declared:
        notes.append(f"{declared} gears declared, the data show {len(ratios)}: "
                     f"{declared - len(ratios)} gear(s) never seen locked in these tests")
    return GearFit(ratios=np.asarray(ratios), samples=counts, spread=spread,
                   locked_in_data=locked, declared=declared, notes=notes)


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


def lockup_speeds(traces, gears, locks, n_gears: int, v_cap: float,
                  ratios=None, wheel_radius_m: float = 0.0,
                  locked_in_data=None) -> tuple[list[float], list[str]]:
    """Per gear: the speed [m/s, floored] above which the converter is locked (the threshold
    that misclassifies the fewest of the gear's samples: locked below + open above), and how
    it was found.

    A gear with fewer than 20 locked samples (seen too briefly) takes the median lock-up
    *engine* speed of the identified gears, turned into its vehicle speed with ``ratios``
    (``assumed``); a gear never locked (an unlocked first gear) gets ``v_cap``."""
    v = np.concatenate([t.v for t in traces])
    g = np.concatenate(gears)
    lk = np.concatenate(locks)
    out: list[float | None] = []
    how: list[str] = []
    for k in range(1, n_gears + 1):
        m = g == k
        if locked_in_data is not None and not locked_in_data[k - 1]:
            out.append(None)
            how.append("never locked")
            continue
        if np.count_nonzero(lk & m) < 20:
            out.append(None)
            how.append("assumed" if np.any(lk & m) else "never locked")
            continue
        vm, lm = v[m], lk[m]
        order = np.argsort(vm)
        vs, ls = vm[order], lm[order].astype(int)
        # decision stump: v* minimising locked samples below it + open samples above it
        below_locked = np.r_[0, np.cumsum(ls)]
        above_open = np.r_[np.cumsum((1 - ls)[::-1])[::-1], 0]
        j = int(np.argmin(below_locked + above_open))
        share = float(ls[j:].mean()) if j < ls.size else 0.0
        if j >= ls.size or share < 0.5:
            out.append(v_cap)
            how.append("identified: mostly open")
            continue
        out.append(float(np.floor(vs[j])))
        how.append("identified")
    known = [(k, x) for k, x in enumerate(out) if x is not None and how[k] == "identified"
             and x < v_cap]
    w_lock = (float(np.median([x * ratios[k] / wheel_radius_m for k, x in known]))
              if known and ratios is not None and wheel_radius_m > 0 else None)
    res = []
    for k, x in enumerate(out):
        if x is None:
            x = (v_cap if how[k] == "never locked" or w_lock is None
                 else float(np.round(w_lock * wheel_radius_m / ratios[k])))
        res.append(float(x))
    return res, how


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

    Least squares of speed on load when a pair has >= 4 shifts over a load spread > 0.15;
    otherwise (few shifts, or all at one load: a line cannot be fitted) the pair takes the
    line shared by every pair in engine speed (lower gear), ``w = a + b load``, fitted the same
    way on all shifts of that kind, turned into the pair's vehicle speed.
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
        # shared line in engine speed (lower gear): w = a + b load, over every pair's shifts
        allp = np.asarray([(v * ratios[i] / wheel_radius_m, ld) for i in range(n)
                           for v, ld in per_pair[i]]).reshape(-1, 2)
        wb0: float | None
        wb1: float = 0.0
        if len(allp) >= 4 and np.ptp(allp[:, 1]) > 0.15:
            wb1, _ = np.polyfit(allp[:, 1], allp[:, 0], 1)
            wb1 = max(float(wb1), 0.0)
            wb0 = float(np.median(allp[:, 0] - wb1 * allp[:, 1]))
        elif len(allp):
            wb0, wb1 = float(np.median(allp[:, 0])), 0.0
        else:
            wb0 = None
        z, f = [], []
        for i in range(n):
            pts = np.asarray(per_pair[i]) if per_pair[i] else np.zeros((0, 2))
            if len(pts) >= 4 and np.ptp(pts[:, 1]) > 0.15:
                b1, b0 = np.polyfit(pts[:, 1], pts[:, 0], 1)
                b1 = max(b1, 0.0)
                b0 = float(np.median(pts[:, 0] - b1 * pts[:, 1]))
            elif wb0 is not None:
                k = wheel_radius_m / ratios[i]
                b0, b1 = wb0 * k, wb1 * k
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
