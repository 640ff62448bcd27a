"""Identify the drive cycle a test drove from its measured vehicle speed.

The measured speed is averaged into 1 s bins and compared with every package cycle
(:func:`vehval.cycles.list_cycles`) at every start offset at once (a sliding RMS error
computed with cross-correlations). The pre-test padding (the D3 files start at -10 s) and
any idle before, between or after the runs cost nothing: a cycle may start anywhere in the
record, may occur several times (HWFET x2, US06 x2, UDDS + UDDS for an FTP-type test with
a soak between the runs), and the FTP-75 may be split by its 10 min hot soak before bag 3.

A cycle is accepted when

* each occurrence follows the cycle with an RMS speed error below ``max_rms_mps``
  (1 m/s by default; a driver on a dyno typically stays within 0.2-0.6 m/s),
* each occurrence covers at least ``min_coverage`` of the cycle's duration (90 %), and
* the occurrences together explain at least ``min_explained`` of the time the vehicle
  moves (90 %), so a test that drove something else as well is not called a cycle.

When several cycles pass (the NEDC also contains four ECE-15), the one explaining the most
driving wins, then the one needing the fewest repeats, then the lowest RMS error. When no
cycle passes, a test whose moving time is mostly spent on constant-speed plateaus is a
steady-speed test (``steady_<kph>kph`` for one plateau, ``steady`` for several).

Examples
--------
>>> from vehval.cycles import load_cycle
>>> c = load_cycle("us06")
>>> name, score, details = identify_cycle(c.time_s + 12.0, c.speed_mps)
>>> name, details["offset_s"], details["rms_mps"] < 1e-6
('us06', 12.0, True)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from vehval.cycles import part_boundary_s
from vehval.errors import VehvalError
from vehval.integrals import integral

__all__ = ["identify_cycle", "identify_scaled", "run_distance_ratios", "describe", "MAX_RMS_MPS", "MIN_COVERAGE", "MIN_EXPLAINED",
           "MOVING_MPS", "SPLIT_AT_S"]


def correlate(a: np.ndarray, v: np.ndarray, mode: str = "full", method: str = "fft") -> np.ndarray:
    """Cross-correlation of two real 1-D arrays by FFT (numpy), as ``scipy.signal.correlate``.

    ``mode`` is ``full`` (``len(a) + len(v) - 1`` lags) or ``valid`` (``len(a) - len(v) + 1``,
    ``len(a) >= len(v)``). numpy's FFT instead of scipy.signal keeps a command's start-up
    short: importing scipy.signal costs about a second of CPU.
    """
    a = np.asarray(a, float)
    v = np.asarray(v, float)
    n = a.size + v.size - 1
    if a.size == 0 or v.size == 0:
        return np.zeros(0)
    nfft = 1 << max(1, (n - 1).bit_length())
    full = np.fft.irfft(np.fft.rfft(a, nfft) * np.fft.rfft(v[::-1], nfft), nfft)[:n]
    if mode == "full":
        return full
    if mode == "valid":
        return full[v.size - 1:a.size]
    raise ValueError(f"mode {mode!r}: full or valid")

#: Largest RMS speed error [m/s] of an accepted occurrence.
MAX_RMS_MPS = 1.0
#: Smallest fraction of the cycle duration an occurrence must cover (measured data present).
MIN_COVERAGE = 0.9
#: Smallest fraction of the moving time the accepted occurrences must explain.
MIN_EXPLAINED = 0.9
#: Speed above which the vehicle counts as moving [m/s].
MOVING_MPS = 0.5
#: Cycles that may be split by a soak: name -> split time [s] in the cycle. The FTP-75 runs
#: bag 3 (the first 505 s of the UDDS again) after a 10 min hot soak (40 CFR 86.137); the
#: package trace leaves the soak out, a measured file usually keeps it.
SPLIT_AT_S = {"ftp75": part_boundary_s("ftp75", "bag2")}
#: Longest soak accepted between the two parts of a split cycle [s].
MAX_SOAK_S = 1500.0
#: Steady-speed plateaus: speed band [m/s] around the plateau median, shortest hold [s],
#: lowest plateau speed [m/s], and the share of moving time they must cover.
PLATEAU_BAND_MPS = 0.5
PLATEAU_MIN_S = 30.0
PLATEAU_MIN_MPS = 1.0
STEADY_MIN_FRACTION = 0.6


@dataclass
class _Grid:
    """The measured speed on a 1 s grid: ``v[i]`` is the mean speed over ``t0 + i ± 0.5 s``."""

    t0: float
    v: np.ndarray
    valid: np.ndarray

    @property
    def moving(self) -> np.ndarray:
        return self.valid & (self.v > MOVING_MPS)


@dataclass
class _Match:
    """One candidate cycle: where it occurs in the record and how well."""

    cycle: str
    repeats: int = 0
    lags: list[int] = field(default_factory=list)      # grid index of cycle t = 0
    offsets_s: list[float] = field(default_factory=list)
    rms: list[float] = field(default_factory=list)
    coverage: list[float] = field(default_factory=list)
    windows: list[tuple[int, int]] = field(default_factory=list)
    explained: float = 0.0
    split: bool = False

    @property
    def rms_mps(self) -> float:
        """RMS error over all occurrences [m/s] (inf when none)."""
        return float(np.sqrt(np.mean(np.square(self.rms)))) if self.rms else float("inf")

    @property
    def name(self) -> str:
        return self.cycle if self.repeats <= 1 else f"{self.cycle}_x{self.repeats}"

    def summary(self) -> dict[str, Any]:
        return {"cycle": self.cycle, "repeats": self.repeats, "split_by_soak": self.split,
                "rms_mps": _r(self.rms_mps), "offsets_s": [_r(o, 1) for o in self.offsets_s],
                "coverage": _r(min(self.coverage), 3) if self.coverage else 0.0,
                "explained": _r(self.explained, 3)}


def _r(x: float, nd: int = 3) -> float:
    return round(float(x), nd) + 0.0 if np.isfinite(x) else float("inf")


# ------------------------------------------------------------------------------ inputs
#: Longest record searched for a drive cycle [s]: a week (a 1 s grid of 604,800 points).
MAX_MATCH_SPAN_S = 7 * 86400.0


def _bin_1hz(time_s: np.ndarray, speed_mps: np.ndarray) -> _Grid:
    """The speed on a 1 s grid: the mean of each 1 s bin for data faster than 4 Hz, linear
    interpolation for slower loggers; grid points more than 2 s from any sample (logging
    gaps) are invalid."""
    t = np.asarray(time_s, dtype=float).ravel()
    v = np.asarray(speed_mps, dtype=float).ravel()
    if t.shape != v.shape:
        raise VehvalError(f"identify_cycle: time ({t.size} values) and speed ({v.size} values) "
                          "must have the same length")
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], np.maximum(v[ok], 0.0)
    order = np.argsort(t, kind="stable")
    t, v = t[order], v[order]
    if t.size < 2 or not (10.0 <= t[-1] - t[0] <= MAX_MATCH_SPAN_S):
        # shorter than any cycle, or a time base no drive cycle can be found in (a damaged
        # timestamp of 4e300 s would ask for a 1 s grid beyond any memory): no match
        return _Grid(0.0, np.zeros(0), np.zeros(0, dtype=bool))
    t0 = float(np.ceil(t[0] - 0.5))
    n = int(np.floor(t[-1] + 0.5 - t0)) + 1
    grid = t0 + np.arange(n, dtype=float)
    out = np.interp(grid, t, v)
    if np.median(np.diff(t)) <= 0.25:  # fast data: the mean over each 1 s bin (less noise)
        idx = np.clip(np.floor(t - t0 + 0.5).astype(np.int64), 0, n - 1)
        counts = np.bincount(idx, minlength=n)
        sums = np.bincount(idx, weights=v, minlength=n)
        out = np.where(counts > 0, sums / np.maximum(counts, 1), out)
    j = np.clip(np.searchsorted(t, grid), 1, t.size - 1)
    nearest = np.minimum(np.abs(grid - t[j - 1]), np.abs(t[j] - grid))
    valid = nearest <= 2.0  # a logging gap longer than ~4 s is missing data, not a ramp
    return _Grid(t0, np.where(valid, out, 0.0), valid)


@lru_cache(maxsize=64)
def _cycle_1hz(name: str) -> np.ndarray:
    """Package cycle ``name`` on a 1 s grid from its t = 0 [m/s] (read-only)."""
    from vehval.cycles import load_cycle

    c = load_cycle(name)
    grid = c.time_s[0] + np.arange(int(np.floor(c.duration_s + 1e-9)) + 1, dtype=float)
    v = np.interp(grid, c.time_s, c.speed_mps)
    v.setflags(write=False)
    return v


# ------------------------------------------------------------------------------ matching
def _sliding_rms(g: _Grid, c: np.ndarray, pad: int) -> tuple[np.ndarray, np.ndarray]:
    """RMS error [m/s] and coverage (0..1) of cycle ``c`` started at every lag.

    Lag ``k`` puts cycle sample 0 on grid index ``k - pad``; the record is padded with
    ``pad`` invalid samples on each side so a cycle may overhang either end a little.
    """
    m = c.size
    w = np.concatenate([np.zeros(pad), g.valid.astype(float), np.zeros(pad)])
    vw = np.concatenate([np.zeros(pad), g.v, np.zeros(pad)]) * w
    if w.size < m:
        return np.zeros(0), np.zeros(0)
    def window_sum(x: np.ndarray) -> np.ndarray:
        cs = np.concatenate([[0.0], np.cumsum(x)])
        return cs[m:] - cs[:-m]

    s_vv = window_sum(vw * vw)
    s_vc = correlate(vw, c, mode="valid", method="fft")
    s_cc = correlate(w, c * c, mode="valid", method="fft")
    n_w = window_sum(w)
    sse = np.maximum(s_vv - 2.0 * s_vc + s_cc, 0.0)
    n_w = np.round(n_w)
    rms = np.sqrt(sse / np.maximum(n_w, 1.0))
    rms[n_w < 1] = np.inf
    return rms, n_w / m


def _refine(g: _Grid, c: np.ndarray, start: int) -> tuple[float, float]:
    """Sub-second start [s on the record's clock] and RMS error [m/s] around grid index
    ``start`` (golden-section search of the RMS over ±1 s, linear interpolation)."""
    tc = np.arange(c.size, dtype=float)
    grid = g.t0 + np.arange(g.v.size, dtype=float)

    def err(s: float) -> float:
        tt = g.t0 + start + s + tc
        inside = (tt >= grid[0]) & (tt <= grid[-1])
        ok = inside.copy()
        ok[inside] = np.interp(tt[inside], grid, g.valid.astype(float)) > 0.999
        if not ok.any():
            return float("inf")
        d = np.interp(tt[ok], grid, g.v) - c[ok]
        return float(np.sqrt(np.mean(d * d)))

    a, b = -1.0, 1.0
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    x1, x2 = b - ratio * (b - a), a + ratio * (b - a)
    f1, f2 = err(x1), err(x2)
    for _ in range(24):
        if f1 <= f2:
            b, x2, f2 = x2, x1, f1
            x1 = b - ratio * (b - a)
            f1 = err(x1)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + ratio * (b - a)
            f2 = err(x2)
    s, f = (x1, f1) if f1 <= f2 else (x2, f2)
    f0 = err(0.0)
    if f0 <= f:
        s, f = 0.0, f0
    return g.t0 + start + s, f


def _occurrences(g: _Grid, c: np.ndarray, max_rms: float, min_cov: float,
                 max_count: int = 12) -> list[tuple[int, float, float]]:
    """Non-overlapping starts (grid index, rms, coverage) of ``c``, best first."""
    pad = int(np.floor((1.0 - min_cov) * c.size))
    rms, cov = _sliding_rms(g, c, pad)
    if rms.size == 0:
        return []
    ok = (rms <= max_rms) & (cov >= min_cov - 1e-9)
    score = np.where(ok, rms, np.inf)
    sep = c.size - round(0.05 * c.size)
    out: list[tuple[int, float, float]] = []
    while len(out) < max_count:
        k = int(np.argmin(score))
        if not np.isfinite(score[k]):
            break
        out.append((k - pad, float(rms[k]), float(cov[k])))
        score[max(0, k - sep + 1): k + sep] = np.inf
    return out


def _explained(g: _Grid, windows: list[tuple[int, int]]) -> float:
    moving = g.moving
    n = int(moving.sum())
    if n == 0:
        return 0.0
    cover = np.zeros(g.v.size, dtype=bool)
    for a, b in windows:
        cover[max(a, 0): max(min(b, g.v.size), 0)] = True
    return float((moving & cover).sum()) / n


def _match(g: _Grid, name: str, max_rms: float, min_cov: float) -> _Match:
    c = _cycle_1hz(name)
    m = _Match(name)
    for k, _, cov in sorted(_occurrences(g, c, max_rms, min_cov), key=lambda o: o[0]):
        start_s, rms = _refine(g, c, k)
        m.lags.append(k)
        m.offsets_s.append(start_s)
        m.rms.append(rms if np.isfinite(rms) else float("inf"))
        m.coverage.append(cov)
        m.windows.append((k, k + c.size))
    m.repeats = len(m.lags)
    m.explained = _explained(g, m.windows)
    return m


def _match_split(g: _Grid, name: str, split_s: float, max_rms: float, min_cov: float) -> _Match:
    """A cycle run in two parts separated by a soak (FTP-75: bags 1-2, soak, bag 3)."""
    c = _cycle_1hz(name)
    cut = round(split_s)
    head, tail = c[:cut + 1], c[cut + 1:]
    m = _Match(name, split=True)
    heads = _occurrences(g, head, max_rms, min_cov, max_count=4)
    tails = _occurrences(g, tail, max_rms, min_cov, max_count=8)
    best = None
    for kh, rh, ch in heads:
        for kt, rt, ct in tails:
            gap = kt - (kh + head.size)
            if 0 <= gap <= MAX_SOAK_S:
                rms = np.sqrt((rh ** 2 * head.size + rt ** 2 * tail.size) / c.size)
                if best is None or rms < best[0]:
                    best = (rms, kh, kt, min(ch, ct))
    if best is None:
        return m
    _, kh, kt, cov = best
    start_s, rh = _refine(g, head, kh)
    _, rt = _refine(g, tail, kt)
    m.lags, m.offsets_s = [kh], [start_s]
    m.rms = [float(np.sqrt((rh ** 2 * head.size + rt ** 2 * tail.size) / c.size))]
    m.coverage, m.windows, m.repeats = [cov], [(kh, kh + head.size), (kt, kt + tail.size)], 1
    m.explained = _explained(g, m.windows)
    return m


# ------------------------------------------------------------------------------ steady
def _plateaus(g: _Grid) -> list[tuple[float, float, float]]:
    """Constant-speed holds: (start [s], end [s], median speed [m/s]) of every run of at
    least ``PLATEAU_MIN_S`` whose speed stays within ``PLATEAU_BAND_MPS`` of its median."""
    v, ok = g.v, g.valid
    out = []
    i, n = 0, v.size
    while i < n:
        if not ok[i] or v[i] < PLATEAU_MIN_MPS:
            i += 1
            continue
        j = i + 1
        ref = v[i]
        while j < n and ok[j] and abs(v[j] - ref) <= PLATEAU_BAND_MPS:
            j += 1
            if j - i in (5, 15, 45):  # settle the reference on the run's median
                ref = float(np.median(v[i:j]))
        if j - i >= PLATEAU_MIN_S:
            out.append((g.t0 + i, g.t0 + j - 1, float(np.median(v[i:j]))))
            i = j
        else:
            i += 1
    return out


def _steady(g: _Grid) -> tuple[str | None, float, list[tuple[float, float, float]]]:
    plats = _plateaus(g)
    moving = int(g.moving.sum())
    if not plats or moving == 0:
        return None, 0.0, plats
    held = sum(b - a + 1 for a, b, _ in plats)
    frac = min(1.0, held / moving)
    if frac < STEADY_MIN_FRACTION:
        return None, frac, plats
    speeds = [p[2] for p in plats]
    if len(plats) == 1 or max(speeds) - min(speeds) <= 2 * PLATEAU_BAND_MPS:
        return f"steady_{round(float(np.median(speeds)) * 3.6):g}kph", frac, plats
    return "steady", frac, plats


# ------------------------------------------------------------------------------ public
def identify_cycle(time_s: Any, speed_mps: Any, *, cycles: list[str] | None = None,
                   max_rms_mps: float = MAX_RMS_MPS, min_coverage: float = MIN_COVERAGE,
                   min_explained: float = MIN_EXPLAINED) -> tuple[str | None, float, dict]:
    """Identify the drive cycle of a measured vehicle speed trace.

    Parameters
    ----------
    time_s : array_like
        Sample times [s] (any rate, any origin; NaN samples are ignored).
    speed_mps : array_like
        Measured vehicle speed [m/s].
    cycles : list of str, optional
        Package cycle names to try (default: all of :func:`vehval.cycles.list_cycles`).
    max_rms_mps : float
        Largest RMS speed error of an accepted occurrence [m/s].
    min_coverage : float
        Smallest share (0..1) of the cycle duration an occurrence must cover with data.
    min_explained : float
        Smallest share (0..1) of the moving time the occurrences must explain.

    Returns
    -------
    name : str or None
        The cycle (``udds``), ``<cycle>_x<n>`` when it was driven ``n`` times in a row
        (``hwfet_x2``), ``steady_<kph>kph`` / ``steady`` for steady-speed tests, or ``None``.
    score : float
        Match quality 0..1: ``explained * (1 - rms / max_rms_mps)`` for a cycle, the share of
        moving time on plateaus for a steady test, 0 when nothing matched.
    details : dict
        ``method`` ("cycle", "steady" or None), ``cycle``, ``repeats``, ``rms_mps``,
        ``offset_s`` (record time of the cycle's t = 0 [s]), ``offsets_s``, ``windows_s``
        (record-time [start, end] of each matched piece, 1 s resolution), ``coverage``,
        ``explained``, ``split_by_soak``, ``plateaus`` ([start s, end s, speed m/s]),
        ``candidates`` (the best few cycles tried, with their figures) and ``reason`` (why
        nothing matched).
    """
    from vehval.cycles import list_cycles

    g = _bin_1hz(np.asarray(time_s, dtype=float), np.asarray(speed_mps, dtype=float))
    details: dict[str, Any] = {"method": None, "moving_s": float(g.moving.sum()) if g.v.size else 0.0}
    if g.v.size == 0:
        details["reason"] = "fewer than 10 s of valid speed samples"
        return None, 0.0, details
    if not g.moving.any():
        details["reason"] = f"the vehicle never moves (speed <= {MOVING_MPS} m/s)"
        return None, 0.0, details
    names = list(cycles) if cycles is not None else list_cycles()
    matches = []
    for name in names:
        m = _match(g, name, max_rms_mps, min_coverage)
        if name in SPLIT_AT_S and m.explained < min_explained:
            s = _match_split(g, name, SPLIT_AT_S[name], max_rms_mps, min_coverage)
            if s.explained > m.explained:
                m = s
        matches.append(m)
    tried = sorted(matches, key=lambda m: (-m.explained, m.rms_mps))
    details["candidates"] = [m.summary() for m in tried[:4] if m.repeats]
    good = [m for m in matches if m.repeats and m.explained >= min_explained]
    if good:
        top = max(m.explained for m in good)
        best = min((m for m in good if m.explained >= top - 0.05),
                   key=lambda m: (m.repeats, m.rms_mps))
        score = best.explained * max(0.0, 1.0 - best.rms_mps / max_rms_mps)
        details.update(best.summary())
        details.update(method="cycle", offset_s=_r(best.offsets_s[0], 1),
                       windows_s=[[_r(g.t0 + a, 1), _r(g.t0 + b, 1)] for a, b in best.windows])
        return best.name, _r(score, 3), details
    steady, frac, plats = _steady(g)
    details["plateaus"] = [[_r(a, 1), _r(b, 1), _r(v, 3)] for a, b, v in plats]
    if steady is not None:
        details.update(method="steady", steady_fraction=_r(frac, 3))
        return steady, _r(frac, 3), details
    from vehval.cycles_text import no_match_reason

    details.update(steady_fraction=_r(frac, 3), limits={
        "max_rms_mps": max_rms_mps, "min_coverage": min_coverage, "min_explained": min_explained})
    if tried and tried[0].repeats:
        b = tried[0]
        details["best"] = {"name": b.name, "explained": _r(b.explained, 3),
                           "rms_mps": _r(b.rms_mps, 3)}
    details["reason"] = no_match_reason(details)
    return None, 0.0, details


def describe(name: str | None, details: dict, system_name: str | None = None) -> str:
    """One-line account of an identification (:func:`vehval.cycles_text.describe`)."""
    from vehval.cycles_text import describe as text

    return text(name, details, system_name)


# ------------------------------------------------------------------------------ scale
#: Speed scales searched by :func:`identify_scaled`: a trace 0.2..5 times a cycle's. Unit
#: mistakes (km/h for mph: 1.609) lie inside; beyond, no speed channel of a car.
SCALE_RANGE = (0.2, 5.0)


def run_distance_ratios(time_s: Any, speed_mps: Any, details: dict, shift_s: float = 0.0
                        ) -> list[tuple[float, float]]:
    """Measured and cycle distance [m] of every run of an identification.

    Parameters
    ----------
    time_s, speed_mps : array_like
        The measured speed [m/s] at record times [s].
    details : dict
        :func:`identify_cycle` details of a ``cycle`` match (``cycle``, ``offsets_s``,
        ``windows_s``, ``split_by_soak``).
    shift_s : float
        Time shift [s] the speed received since the identification (alignment).

    Returns
    -------
    list of (float, float)
        Per run: (distance the measured speed covers over the run's window, the cycle's own
        distance over the same cycle time) [m]; a window without data counts only where
        data exist.
    """
    from vehval.cycles import load_cycle

    if details.get("method") != "cycle" or not details.get("offsets_s"):
        return []
    cyc = load_cycle(str(details["cycle"]))
    t = np.asarray(time_s, float)
    v = np.asarray(speed_mps, float)
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    if t.size < 2:
        return []
    dur = float(cyc.duration_s)
    split = SPLIT_AT_S.get(str(details["cycle"]))
    if details.get("split_by_soak") and split and len(details.get("windows_s", [])) == 2:
        off = float(details["offsets_s"][0]) + shift_s
        tail = float(details["windows_s"][1][0]) + shift_s - (split + 1.0)
        runs = [[(0.0, split, off), (split, dur, tail)]]
    else:
        runs = [[(0.0, dur, float(o) + shift_s)] for o in details["offsets_s"]]
    out = []
    for pieces in runs:
        meas = ref = 0.0
        for c0, c1, off in pieces:
            tt = np.arange(c0, c1, 0.1)
            inside = (tt + off >= t[0]) & (tt + off <= t[-1])
            if inside.sum() < 2:
                continue
            tt = tt[inside]
            meas += integral(tt, np.interp(tt + off, t, v))
            ref += integral(tt, np.interp(tt, cyc.time_s, cyc.speed_mps))
        out.append((meas, ref))
    return out


def identify_scaled(time_s: Any, speed_mps: Any, *, cycles: list[str] | None = None
                    ) -> tuple[str | None, float, dict]:
    """The cycle a speed trace follows once divided by a constant factor (a speed scale).

    For every cycle the start where the trace has the cycle's shape (largest cosine
    similarity over a whole cycle) gives the least-squares factor ``k`` (trace ≈ k x cycle);
    the trace divided by ``k`` must then pass :func:`identify_cycle` for that cycle.

    Returns
    -------
    name : str or None
        The cycle identified in the scaled trace (``hwfet_x2``), None when none is.
    factor : float
        Measured over cycle distance of its runs together [-] (nan when none).
    details : dict
        :func:`identify_cycle` details of the scaled trace.
    """
    from vehval.cycles import list_cycles

    t = np.asarray(time_s, float)
    v = np.asarray(speed_mps, float)
    g = _bin_1hz(t, v)
    if g.v.size == 0 or not g.moving.any():
        return None, float("nan"), {}
    best: tuple[float, float, str, float, dict] | None = None
    for name in (list(cycles) if cycles is not None else list_cycles()):
        k = _shape_factor(g, _cycle_1hz(name))
        if not (SCALE_RANGE[0] <= k <= SCALE_RANGE[1]):
            continue
        found, _, det = identify_cycle(t, v / k, cycles=[name])
        if found is None or det.get("method") != "cycle":
            continue
        key = (-float(det["explained"]), float(det["rms_mps"]))
        if best is None or key < (best[0], best[1]):
            best = (key[0], key[1], found, k, det)
    if best is None:
        return None, float("nan"), {}
    _, _, found, k, det = best
    runs = run_distance_ratios(t, v / k, det)
    ref = sum(r for _, r in runs)
    factor = k * sum(m for m, _ in runs) / ref if ref > 0 else k
    return found, float(factor), det


def _shape_factor(g: _Grid, c: np.ndarray) -> float:
    """Least-squares factor of the trace over cycle ``c`` where the two are most alike in
    shape (the largest cosine similarity over windows covering ``MIN_COVERAGE``); nan when
    the trace is shorter than the cycle."""
    m = c.size
    w = g.valid.astype(float)
    vw = g.v * w
    if w.size < m:
        return float("nan")
    cs = np.concatenate([[0.0], np.cumsum(vw * vw)])
    s_vv = cs[m:] - cs[:-m]
    s_vc = correlate(vw, c, mode="valid")
    s_cc = correlate(w, c * c, mode="valid")
    cn = np.concatenate([[0.0], np.cumsum(w)])
    cover = (cn[m:] - cn[:-m]) / m
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = np.where((cover >= MIN_COVERAGE) & (s_vv > 0) & (s_cc > 0),
                       s_vc / np.sqrt(s_vv * s_cc), -np.inf)
    i = int(np.argmax(cos))
    if not np.isfinite(cos[i]) or s_cc[i] <= 0:
        return float("nan")
    return float(s_vc[i] / s_cc[i])
