"""Time alignment between acquisition systems (sources).

Each file of a test (dyno 10 Hz, OBD ~1 Hz with jitter, a DAQ...) has its own clock. The
offset between two sources is estimated from pairs of signals that should match in time:
the same quantity measured by both (same base name, e.g. ``eng_spd_out_test`` and
``eng_spd_out_obd_test``) or, failing those, quantities that are strongly correlated
(vehicle speed and wheel speed, engine torque and fuel rate...).

Method, for each pair:

0. samples without timing information are set aside: values outside the registry's
   plausible range (an invalid PID value such as 80 m/s would dominate the variance and
   drag the peak) and isolated spikes (:func:`_plausible`);
1. both signals are resampled on a common grid (the faster sample period) over their
   overlapping span, normalised (zero mean, unit variance; NaN excluded);
2. the normalised cross-correlation is computed with FFTs and divided by the number of
   overlapping valid samples at each lag, over the search range (default ±30 s);
3. the mismatch ``1 - corr(slow samples, fast signal interpolated at slow times + d)`` is
   scanned on the fine step over the main lobe of the grid correlation (at most ±10 s: the
   lobe of slowly varying signals is broad and its top unreliable), then refined to
   sub-sample accuracy by a bounded minimisation around the best scan point: the slower
   signal is used at its own sample times and the faster, better-resolved signal is
   interpolated, so no information is smeared;
4. confidence = peak correlation × (1 − second-peak ratio), where the second peak is the
   highest local maximum outside the main lobe.

Pairs are combined by a confidence-weighted median, refined by the weighted mean of the
pairs within one sample of the faster source of it (a pair spoiled by a stuck or invalid
stretch is left out rather than averaged in); the agreement between pairs scales the final
confidence. Sign convention: ``offset_s`` is added to the timestamps of the
source (:meth:`vehval.test.Test.shift_source`), i.e. ``ref(t) = other(t - offset_s)``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from vehval.cycles_match import correlate
from vehval.errors import SignalError
from vehval.nomenclature import registry
from vehval.test import Signal, Test

#: Base-name pairs that should be strongly (positively) correlated in time.
CORRELATED_BASES: tuple[tuple[str, str], ...] = (
    ("veh_spd", "whl_spd"),
    ("veh_spd", "dyno_spd"),
    ("veh_spd", "mot_spd_out"),
    ("veh_spd", "fd_spd_in"),
    ("veh_spd", "pg_spd_ring"),
    ("whl_spd", "mot_spd_out"),
    ("veh_frc_in", "whl_trq_out"),
    ("veh_frc_in", "veh_pwr_in"),
    ("eng_trq_out", "fuel_rate"),
    ("eng_pwr_out", "fuel_rate"),
    ("eng_pwr_out", "eng_trq_out"),
    ("eng_spd_out", "eng_spd_target"),
    ("eng_spd_out", "fuel_rate"),
    ("ess_curr", "ess_pwr"),
    ("mot_trq_out", "whl_trq_out"),
    ("drv_pos_accel", "eng_pos_throttle"),
)


@dataclass
class PairResult:
    """Offset estimate from one pair of signals."""

    ref: str
    other: str
    kind: str                     # "duplicate", "correlated" or "user"
    offset_s: float
    peak_corr: float
    second_ratio: float
    confidence: float
    corr_before: float
    corr_after: float

    def to_dict(self) -> dict:
        return {k: (float(v) if isinstance(v, (float, np.floating)) else v)
                for k, v in self.__dict__.items()}


@dataclass
class AlignmentResult:
    """Alignment of one source against the reference source.

    Attributes
    ----------
    source : str
        Source tag aligned.
    reference : str
        Source it was aligned to.
    offset_s : float
        Estimated offset [s] added to the source's timestamps (NaN when no pair).
    confidence : float
        0..1: peak correlation × peak sharpness × agreement between pairs.
    applied : bool
        Whether the shift was applied to the test.
    pairs : list of PairResult
        Every pair used, with its own estimate.
    corr_before, corr_after : float
        Mean correlation of the pairs before and after the shift.
    message : str
        Plain explanation (why not applied, which pairs...).
    """

    source: str
    reference: str
    offset_s: float
    confidence: float
    applied: bool
    pairs: list[PairResult] = field(default_factory=list)
    corr_before: float = float("nan")
    corr_after: float = float("nan")
    agreement: float = float("nan")
    message: str = ""

    def to_dict(self) -> dict:
        def f(x):
            return None if x is None or (isinstance(x, float) and not np.isfinite(x)) else float(x)
        return {"source": self.source, "reference": self.reference, "offset_s": f(self.offset_s),
                "confidence": f(self.confidence), "applied": self.applied,
                "corr_before": f(self.corr_before), "corr_after": f(self.corr_after),
                "agreement": f(self.agreement), "message": self.message,
                "pairs": [{k: (f(v) if isinstance(v, (float, np.floating)) else v)
                           for k, v in p.to_dict().items()} for p in self.pairs]}


def _base(name: str) -> str | None:
    try:
        return registry().parse(name).base
    except SignalError:
        return None


def _period(sig: Signal) -> float:
    p = sig.sample_period
    return p if np.isfinite(p) and p > 0 else 1.0


def reference_source(test: Test) -> str:
    """The reference source: most ``_test`` signals, then fastest sample rate."""
    stats: dict[str, tuple[int, float]] = {}
    for sig in test:
        if sig.name.endswith("_calc") or sig.name.endswith("_simu"):
            continue
        n, p = stats.get(sig.source, (0, np.inf))
        stats[sig.source] = (n + 1, min(p, _period(sig)))
    if not stats:
        raise SignalError("cannot align: the test has no measured signals")
    return max(stats, key=lambda s: (stats[s][0], -stats[s][1], s == "", s))


def _pearson(a: np.ndarray, b: np.ndarray) -> float:
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 3:
        return float("nan")
    a, b = a[ok] - a[ok].mean(), b[ok] - b[ok].mean()
    den = np.sqrt((a * a).sum() * (b * b).sum())
    return float((a * b).sum() / den) if den > 0 else float("nan")


def _interp(sig: Signal, t: np.ndarray) -> np.ndarray:
    """Linear interpolation (NaN outside the span) — the hot path of the refinement."""
    return np.interp(t, sig.time, sig.values, left=np.nan, right=np.nan)


def _plausible(sig: Signal) -> Signal:
    """The signal without the samples that carry no timing information (set to NaN).

    * values outside the registry's plausible range (an invalid PID value such as 127.5 %
      SOC or 80 m/s dominates the variance and drags the correlation peak);
    * isolated spikes: one or two samples leaving their neighbours by more than 10 robust
      sigmas and 20 % of the robust range and coming back (a Hampel filter of 5 samples, the
      rule of QA level 1); interpolated at a shifted time they make the fine correlation
      jump with the shift.
    """
    v = np.asarray(sig.values, float)
    bad = np.zeros(v.size, bool)
    try:
        lo, hi = registry().spec_of(sig.name).range
        bad |= (v < lo) | (v > hi)
    except (SignalError, KeyError, AttributeError):
        pass
    if v.size >= 5:
        from numpy.lib.stride_tricks import sliding_window_view
        resid = np.full(v.size, np.nan)
        resid[2:-2] = v[2:-2] - np.median(sliding_window_view(v, 5), axis=1)
        fin = np.isfinite(resid)
        if fin.any():
            sigma = 1.4826 * float(np.median(np.abs(resid[fin])))
            f = v[np.isfinite(v)]
            rrange = float(np.ptp(np.percentile(f, [0.5, 99.5]))) if f.size else 0.0
            out = fin & (np.abs(resid) > max(10 * sigma, 0.2 * rrange)) & (rrange > 0)
            for i in np.flatnonzero(out):
                lo_i, hi_i = max(int(i) - 1, 0), min(int(i) + 1, v.size - 1)
                if abs(v[hi_i] - v[lo_i]) <= 0.5 * abs(resid[i]):   # leaves and returns
                    bad[i] = True
    if not bad.any():
        return sig
    return replace(sig, values=np.where(bad, np.nan, v))


def _fine_corr(ref: Signal, other: Signal, d: float, other_slower: bool | None = None) -> float:
    """Correlation of the slower signal at its own times with the faster one interpolated."""
    if other_slower is None:
        other_slower = _period(other) >= _period(ref)
    if other_slower:
        return _pearson(other.values, _interp(ref, other.time + d))
    return _pearson(ref.values, _interp(other, ref.time - d))


def estimate_pair(ref: Signal, other: Signal, max_offset_s: float = 30.0,
                  kind: str = "duplicate", refine: bool = True) -> PairResult | None:
    """Estimate the offset of ``other`` relative to ``ref`` [s].

    Parameters
    ----------
    ref, other : Signal
        Signals that should match in time (same quantity or strongly correlated).
    max_offset_s : float
        Search range ±[s].
    kind : str
        Label recorded in the result.
    refine : bool
        Refine the parabolic estimate by minimising the mismatch (sub-sample); without it
        the accuracy is about a tenth of the faster sample period.

    Returns
    -------
    PairResult or None
        ``None`` when the overlap is too short or a signal does not vary.
    """
    ref, other = _plausible(ref), _plausible(other)
    t0 = max(ref.time[0], other.time[0])
    t1 = min(ref.time[-1], other.time[-1])
    p_ref, p_oth = _period(ref), _period(other)
    slower = p_oth >= p_ref
    dt = min(p_ref, p_oth)
    if not np.isfinite(t1 - t0) or t1 - t0 < 10 * max(p_ref, p_oth):
        return None
    grid = t0 + dt * np.arange(int((t1 - t0) / dt) + 1)
    a, b = ref.at(grid), other.at(grid)
    va, vb = np.isfinite(a), np.isfinite(b)
    if va.sum() < 10 or vb.sum() < 10:
        return None
    sa, sb = np.nanstd(a), np.nanstd(b)
    if not (sa > 0 and sb > 0):
        return None
    a = np.where(va, (a - np.nanmean(a)) / sa, 0.0)
    b = np.where(vb, (b - np.nanmean(b)) / sb, 0.0)
    n = grid.size
    max_lag = int(min(max_offset_s, 0.5 * (t1 - t0)) / dt)
    c = correlate(a, b, mode="full", method="fft")
    cnt = correlate(va.astype(float), vb.astype(float), mode="full", method="fft")
    lags = np.arange(-(n - 1), n)
    sel = np.abs(lags) <= max_lag
    c, cnt, lags = c[sel], np.round(cnt[sel]), lags[sel]
    with np.errstate(invalid="ignore", divide="ignore"):
        cn = np.where(cnt >= max(10, 0.25 * n), c / cnt, -np.inf)
    k = int(np.argmax(cn))
    peak = float(cn[k])
    if not np.isfinite(peak):
        return None
    # second peak: highest local maximum outside the main lobe
    left = k
    while left > 0 and cn[left - 1] <= cn[left]:
        left -= 1
    right = k
    while right < cn.size - 1 and cn[right + 1] <= cn[right]:
        right += 1
    outside = np.concatenate([cn[:left], cn[right + 1:]])
    second = float(outside.max()) if outside.size and np.isfinite(outside.max()) else 0.0
    coarse = lags[k] * dt
    # sub-sample refinement: parabola, then bounded minimisation of the mismatch
    if 0 < k < cn.size - 1 and np.isfinite(cn[k - 1]) and np.isfinite(cn[k + 1]):
        den = cn[k - 1] - 2 * cn[k] + cn[k + 1]
        if den < 0:
            coarse += 0.5 * (cn[k - 1] - cn[k + 1]) / den * dt
    def cost(d: float) -> float:
        r = _fine_corr(ref, other, d, slower)
        return -r if np.isfinite(r) else 1.0

    offset = float(coarse)
    r_coarse = -cost(coarse)
    r_after = r_coarse
    if refine:
        # the grid correlation of slowly varying signals (a highway speed trace) has a broad
        # lobe whose top the overlap weighting can move by seconds: scan the fine mismatch
        # over the main lobe (at most ±10 s) on the fine step, then refine around its minimum
        lo_d = max(lags[left] * dt, coarse - 10.0)
        hi_d = min(lags[right] * dt, coarse + 10.0)
        span = 1.5 * max(p_ref, p_oth, dt)
        lo_d, hi_d = min(lo_d, coarse - span), max(hi_d, coarse + span)
        scan = np.arange(lo_d, hi_d + 0.5 * dt, dt)
        costs = np.array([cost(d) for d in scan])
        best = float(scan[int(np.argmin(costs))]) if costs.size else coarse
        if costs.size and costs.min() < cost(coarse):
            coarse = best
        from scipy.optimize import minimize_scalar  # on use: scipy.optimize is slow to import

        res = minimize_scalar(cost, bounds=(coarse - 1.5 * dt, coarse + 1.5 * dt),
                              method="bounded", options={"xatol": dt / 200})
        if res.success and -res.fun >= -cost(coarse) - 1e-12:
            offset, r_after = float(res.x), float(-res.fun)
        elif -cost(coarse) > r_after:
            offset, r_after = float(coarse), float(-cost(coarse))
    ratio = max(second, 0.0) / peak if peak > 0 else 1.0
    conf = max(0.0, r_after) * max(0.0, 1.0 - ratio)
    return PairResult(ref=ref.name, other=other.name, kind=kind, offset_s=offset,
                      peak_corr=float(r_after), second_ratio=float(ratio), confidence=float(conf),
                      corr_before=_fine_corr(ref, other, 0.0, slower), corr_after=float(r_after))


def candidate_pairs(test: Test, ref_source: str, source: str) -> list[tuple[str, str, str]]:
    """Pairs ``(ref_name, other_name, kind)`` between two sources from the nomenclature.

    Duplicated quantities (same base name) are used when any exist; otherwise the
    correlated base pairs of :data:`CORRELATED_BASES`.
    """
    ref_sigs = [s for s in test if s.source == ref_source and s.name.endswith("_test")]
    oth_sigs = [s for s in test if s.source == source and s.name.endswith("_test")]
    rb = {s.name: _base(s.name) for s in ref_sigs}
    ob = {s.name: _base(s.name) for s in oth_sigs}
    dup = [(r, o, "duplicate") for r, b1 in rb.items() for o, b2 in ob.items()
           if b1 is not None and b1 == b2]
    if dup:
        return dup
    corr = []
    for r, b1 in rb.items():
        for o, b2 in ob.items():
            if b1 and b2 and ((b1, b2) in CORRELATED_BASES or (b2, b1) in CORRELATED_BASES):
                corr.append((r, o, "correlated"))
    return corr


def _combine(pairs: list[PairResult], tol_s: float) -> tuple[float, float, float]:
    """Confidence-weighted median offset, agreement fraction, combined confidence."""
    offs = np.array([p.offset_s for p in pairs])
    w = np.array([max(p.confidence, 1e-6) for p in pairs])
    order = np.argsort(offs)
    cw = np.cumsum(w[order])
    off = float(offs[order][np.searchsorted(cw, 0.5 * cw[-1])])
    near = np.abs(offs - off) <= tol_s
    agreement = float(w[near].sum() / w.sum())
    # refine: weighted mean of the agreeing pairs (sub-sample)
    off = float(np.average(offs[near], weights=w[near]))
    conf = float(np.max(w[near]) * agreement) if near.any() else 0.0
    return off, agreement, conf


def align_test(test: Test, pairs: list[tuple[str, str]] | None = None, *,  # noqa: PLR0912 - one branch per way a source pair can fail to align, each named in the result
               reference: str | None = None, max_offset_s: float = 30.0,
               min_confidence: float = 0.3, apply: bool = True) -> list[AlignmentResult]:
    """Estimate and (optionally) remove the clock offsets between the sources of a test.

    Parameters
    ----------
    test : Test
        The test; modified in place when ``apply`` (via :meth:`Test.shift_source`).
    pairs : list of (str, str), optional
        User-named pairs ``(signal_a, signal_b)`` of different sources. When given for a
        source they replace the automatic choice for that source.
    reference : str, optional
        Reference source (default :func:`reference_source`).
    max_offset_s : float
        Search range ±[s].
    min_confidence : float
        Below this confidence the offset is reported but not applied.
    apply : bool
        Apply the shifts to the test.

    Returns
    -------
    list of AlignmentResult
        One per non-reference source.
    """
    ref_src = reference if reference is not None else reference_source(test)
    sources = [s for s in test.sources if s != ref_src and s not in ("calc", "simu")]
    results: list[AlignmentResult] = []
    user: dict[str, list[tuple[str, str]]] = {}
    for a, b in pairs or []:
        sa, sb = test[a].source, test[b].source
        if sa == sb:
            raise SignalError(f"alignment pair ({a}, {b}): both signals come from source "
                              f"'{sa}'; a pair must link two different sources")
        if sb == ref_src:
            a, b, sa, sb = b, a, sb, sa
        user.setdefault(sb, []).append((a, b))
    aligned = {ref_src}
    pending = list(sources)
    for _ in range(len(sources) + 1):
        progress = False
        for src in list(pending):
            if src in user:
                cands = [(a, b, "user") for a, b in user[src]]
            else:
                cands = []
                for anchor in sorted(aligned, key=lambda s: s != ref_src):
                    cands = candidate_pairs(test, anchor, src)
                    if cands:
                        break
            if not cands:
                continue
            est = [r for a, b, k in cands
                   if (r := estimate_pair(test[a], test[b], max_offset_s, k)) is not None]
            pending.remove(src)
            progress = True
            anchor_src = test[cands[0][0]].source
            if not est:
                results.append(AlignmentResult(src, anchor_src, float("nan"), 0.0, False,
                                               message="pairs found but none varies enough "
                                                       "over a long enough overlap"))
                continue
            # pairs agree within one sample of the faster source: wider would let a pair
            # spoiled by a fault (a stuck or invalid stretch) pull the mean
            tol = max(min(min(_period(test[p.ref]), _period(test[p.other])) for p in est), 0.05)
            off, agreement, conf = _combine(est, tol)
            res = AlignmentResult(src, anchor_src, off, conf, False, est,
                                  corr_before=float(np.nanmean([p.corr_before for p in est])),
                                  corr_after=float(np.nanmean([p.corr_after for p in est])),
                                  agreement=agreement)
            names = ", ".join(f"{p.ref}~{p.other}" for p in est)
            if conf >= min_confidence and apply:
                test.shift_source(src, off)
                res.applied = True
                res.message = f"shifted by {off:+.3f} s using {names}"
            elif conf < min_confidence:
                res.message = (f"offset {off:+.3f} s not applied: confidence {conf:.2f} below "
                               f"{min_confidence:.2f} (pairs {names})")
            else:
                res.message = f"offset {off:+.3f} s estimated (not applied) using {names}"
            aligned.add(src)
            results.append(res)
        if not progress:
            break
    for src in pending:
        results.append(AlignmentResult(src, ref_src, float("nan"), 0.0, False,
                                       message="no pair of duplicated or correlated signals "
                                               "links this source to the others; name pairs "
                                               "explicitly to align it"))
    return results
