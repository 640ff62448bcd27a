"""QA level 1: each signal alone.

Checks, per signal: plausible range (registry) and the vehicle's own limits, missing
samples (NaN) and holes in the time base, sample-rate irregularity, stuck segments,
constant or all-zero channels, spikes (Hampel filter) and impossible signs.

Stuck detection is robust to legitimately constant signals: a run of exactly repeated
values counts only when it is non-zero and long enough, and either a partner signal (the
same quantity from another source, or a strongly correlated quantity) moves meanwhile, or
the signal is noisy elsewhere (exact repetition is then beyond its noise). Zero runs count
only against a duplicate of the same quantity that is clearly non-zero meanwhile.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from vehval.align import CORRELATED_BASES
from vehval.errors import SignalError
from vehval.io.importer import TIME_REPAIRED
from vehval.nomenclature import registry
from vehval.qa.findings import Finding, Kind, Severity, merge_runs, runs
from vehval.test import Signal, Test

#: Base names that cannot be negative (beyond sensor noise).
NON_NEGATIVE = frozenset({"fuel_rate", "fuel_pwr", "fuel_mass", "fuel_energy", "brk_frc",
                          "brk_pwr", "brk_pres", "eng_spd_out"})
#: Quantity tokens of signals expected to vary during a drive (constant = suspicious).
DYNAMIC_QUANTITIES = frozenset({"spd", "trq", "frc", "acc", "pwr", "curr", "rate"})
#: Extra correlated bases used only as "partner moves" evidence for stuck detection.
_EXTRA_PARTNERS = (("eng_spd_out", "eng_trq_out"), ("eng_spd_out", "gen_spd_out"),
                   ("mot_spd_out", "whl_spd"), ("veh_spd", "veh_frc_in"),
                   ("ess_curr", "ess_volt"), ("mot_trq_out", "veh_frc_in"))


@dataclass
class Level1Options:
    """Thresholds of QA level 1 (all documented in docs/qa.md)."""

    stuck_min_s: float = 5.0          # shortest exactly-repeated run considered [s]
    stuck_min_samples: int = 4
    noisy_repeat_fraction: float = 0.02   # below: the signal is "noisy" (repeats are rare)
    partner_move_fraction: float = 0.05   # duplicate moves: range in run > this x its range
    correlated_move_fraction: float = 0.2  # same for a merely correlated partner
    spike_corroboration_k: float = 4.0  # partner residual above this x its sigma: real event ...
    spike_corroboration_ratio: float = 0.05  # ... and, relative to its range, at least this
                                      # fraction of the spike's size relative to the signal's range
    spike_k: float = 10.0             # Hampel threshold in robust sigmas
    spike_range_fraction: float = 0.2  # and at least this fraction of the signal range
    spike_window: int = 5             # Hampel window [samples], odd
    gap_factor: float = 2.5           # time gap: step > this x median period
    jitter_info: float = 0.05         # std(dt)/median(dt) above this -> info
    vehicle_limit_tolerance: float = 0.03  # margin: this x the larger |limit|
    max_findings_per_kind: int = 10   # per signal; further runs are merged into one
    max_spikes_corroborated: int = 200  # spikes judged one by one before the cap applies
    out_of_range_fraction: float = 0.1  # above: the whole channel is out of range (error)
    sparse_min_samples: int = 10      # fewer finite samples: too few for any test
    sparse_max_period_s: float = 10.0  # fewer samples than one per this over the test: sparse


def _parse(name: str):
    try:
        return registry().parse(name)
    except SignalError:
        return None


def robust_noise(values: np.ndarray, window: int = 5) -> tuple[float, np.ndarray]:
    """Robust noise sigma and the Hampel residual ``v - rolling median`` (NaN-aware).

    Returns
    -------
    sigma : float
        1.4826 × median absolute residual (same unit as ``values``).
    resid : numpy.ndarray
        Residual per sample (NaN at the edges and around NaN samples).
    """
    v = np.asarray(values, float)
    resid = np.full(v.shape, np.nan)
    h = window // 2
    if v.size < window:
        return 0.0, resid
    med = np.median(sliding_window_view(v, window), axis=1)
    resid[h:v.size - h] = v[h:v.size - h] - med
    r = np.abs(resid[np.isfinite(resid)])
    sigma = 1.4826 * float(np.median(r)) if r.size else 0.0
    return sigma, resid


def _robust_range(v: np.ndarray) -> float:
    f = v[np.isfinite(v)]
    if f.size == 0:
        return 0.0
    lo, hi = np.percentile(f, [0.5, 99.5])
    return float(hi - lo)


def _span(sig: Signal, i0: int, i1: int) -> tuple[float, float]:
    return float(sig.time[i0]), float(sig.time[min(i1, sig.time.size - 1)])


def _emit_runs(out: list[Finding], sig: Signal, rs: list[tuple[int, int]], kind: Kind,
               severity: Severity, text, numbers, opts: Level1Options,
               cap: int | None = None) -> None:
    """One finding per run; beyond the cap (default ``max_findings_per_kind``) the
    remaining runs are merged into one."""
    cap = cap or opts.max_findings_per_kind
    head, tail = rs[:cap - 1], rs[cap - 1:]
    if len(rs) <= cap:
        head, tail = rs, []
    for i0, i1 in head:
        s0, s1 = _span(sig, i0, i1)
        out.append(Finding(sig.name, kind, s0, s1, severity, text(i0, i1), numbers(i0, i1)))
    if tail:
        s0, s1 = _span(sig, tail[0][0], tail[-1][1])
        nums = numbers(tail[0][0], tail[-1][1])
        nums["runs_merged"] = len(tail)
        out.append(Finding(sig.name, kind, s0, s1, severity,
                           f"{len(tail)} more occurrences between {s0:.1f} s and {s1:.1f} s",
                           nums))


def partners_of(test: Test, name: str) -> list[tuple[Signal, bool]]:
    """Signals expected to move with ``name``: ``(signal, is_duplicate)`` pairs."""
    p = _parse(name)
    if p is None:
        return []
    out = []
    for other in test:
        if other.name == name:
            continue
        q = _parse(other.name)
        if q is None or q.origin != "test":
            continue
        if q.base == p.base:
            out.append((other, True))
        elif "target" in p.base or "target" in q.base:
            continue          # a target may legitimately hold while the actual value moves
        elif ((p.base, q.base) in CORRELATED_BASES or (q.base, p.base) in CORRELATED_BASES
              or (p.base, q.base) in _EXTRA_PARTNERS or (q.base, p.base) in _EXTRA_PARTNERS):
            out.append((other, False))
    return out


def _moves(partner: Signal, t0: float, t1: float, frac: float,
           min_abs: float = 0.0, cache: dict | None = None) -> tuple[bool, float]:
    """Does ``partner`` vary within [t0, t1] by more than ``frac`` of its overall range
    (and more than ``min_abs``, e.g. a few quantisation steps of the stuck signal)?"""
    full = cache.get(partner.name) if cache is not None else None
    if full is None:
        full = _robust_range(partner.values)
        if cache is not None:
            cache[partner.name] = full
    if full <= 0:
        return False, 0.0
    sel = (partner.time >= t0) & (partner.time <= t1)
    seg = partner.values[sel]
    seg = seg[np.isfinite(seg)]
    if seg.size < 2:
        return False, 0.0
    rng = float(seg.max() - seg.min())
    return rng > max(frac * full, min_abs), rng / full


def _stuck(test: Test, sig: Signal, base: str, opts: Level1Options,  # noqa: C901, PLR0912 - the stuck-signal exceptions (idle, saturation, held) in turn
           range_cache: dict | None = None) -> list[Finding]:
    v, t = sig.values, sig.time
    if v.size < opts.stuck_min_samples or sig.resample == "previous":
        return []
    same = (np.diff(v) == 0)
    rs = runs(same)                    # run (i0, i1) of diffs -> samples i0..i1+1 equal
    if not rs:
        return []
    cand = []
    for i0, i1 in rs:
        j1 = i1 + 1
        if j1 - i0 + 1 < opts.stuck_min_samples or t[j1] - t[i0] < opts.stuck_min_s:
            continue
        cand.append((i0, j1))
    if not cand:
        return []
    cand_len = sum(j1 - i0 for i0, j1 in cand)
    # how often the signal repeats a value outside the candidate runs; exact zeros (a
    # speed at standstill, a torque with the engine off) are legitimate holds and do not
    # count: they say nothing about the sensor's resolution
    zero_tol = 0.01 * _robust_range(v)
    in_cand = np.zeros(v.size - 1, bool)
    for i0, j1 in cand:
        in_cand[i0:j1] = True
    moving = np.isfinite(np.diff(v)) & (np.abs(v[:-1]) > zero_tol) & ~in_cand
    repeat_frac = int((same & moving).sum()) / max(1, int(moving.sum()))
    covered = cand_len / max(1, v.size - 1)
    noisy = repeat_frac < opts.noisy_repeat_fraction and covered < 0.5
    partners = partners_of(test, sig.name)
    if any(dup for _, dup in partners):
        partners = [(p, dup) for p, dup in partners if dup]
    nz = np.abs(np.diff(v))
    nz = nz[np.isfinite(nz) & (nz > 0)]
    quantum = float(np.median(nz)) if nz.size else 0.0
    found: list[Finding] = []
    for i0, j1 in sorted(cand, key=lambda r: r[0] - r[1])[:50]:
        value = float(v[i0])
        if abs(value) <= zero_tol and not noisy:
            value = 0.0          # quantised "zero" (e.g. -1e-6 kg/s at fuel cut) counts as zero
        t0, t1 = float(t[i0]), float(t[j1])
        mover = None
        for psig, dup in partners:
            if value == 0 and not dup:
                continue
            ok, frac = _moves(psig, t0, t1, opts.partner_move_fraction if dup
                              else opts.correlated_move_fraction, 3 * quantum if dup else 0.0,
                              range_cache)
            if ok and value == 0:
                pv = psig.values[(psig.time >= t0) & (psig.time <= t1)]
                ok = bool(np.nanmedian(np.abs(pv)) > 0.1 * max(_robust_range(psig.values), 1e-12))
            if ok:
                mover = (psig, dup, frac)
                if dup:
                    break
        if value == 0 and mover is None:
            continue
        if mover is not None:
            psig, dup, frac = mover
            sev = Severity.ERROR if dup else Severity.WARNING
            msg = (f"{sig.name} stays exactly at {float(v[i0]):.6g} {sig.unit} for {t1 - t0:.1f} s "
                   f"while {psig.name} varies by {100 * frac:.0f} % of its range")
            nums = {"value": value, "duration_s": t1 - t0, "samples": j1 - i0 + 1,
                    "partner_range_fraction": frac}
            found.append(Finding(sig.name, Kind.STUCK, t0, t1, sev, msg, nums,
                                 related=[psig.name]))
        elif noisy:
            msg = (f"{sig.name} repeats exactly {float(v[i0]):.6g} {sig.unit} for {t1 - t0:.1f} s "
                   f"although it changes at almost every sample elsewhere (stuck sensor?)")
            found.append(Finding(sig.name, Kind.STUCK, t0, t1, Severity.WARNING, msg,
                                 {"value": value, "duration_s": t1 - t0,
                                  "samples": j1 - i0 + 1, "repeat_fraction": repeat_frac}))
    found.sort(key=lambda f: f.start_s)
    return found[:opts.max_findings_per_kind]


def _sparse(sig: Signal, fin: np.ndarray, test_span: tuple[float, float] | None,
            opts: Level1Options) -> Finding | None:
    """A finding when ``sig`` has too few samples for the test (a one-row file beside a
    20-minute log): such a source is never preferred over a complete one."""
    n = int(fin.sum())
    t = sig.time[fin]
    dur = (test_span[1] - test_span[0]) if test_span else 0.0
    if n >= max(opts.sparse_min_samples, dur / opts.sparse_max_period_s):
        return None
    sev = Severity.ERROR if n < 2 else Severity.WARNING
    return Finding(sig.name, Kind.SPARSE, float(t[0]) if n else 0.0, float(t[-1]) if n else 0.0,
                   sev, f"{sig.name} has only {n} valid sample(s) for a test of {dur:.1f} s: too "
                   "few to trust; another source is preferred", {"samples": n, "duration_s": dur})


def _repaired_time_base(sig: Signal, t_start: float, t_end: float) -> list[Finding]:
    """A ``rate_irregular`` error for a time base that went backwards or repeated in the
    file and was sorted at import (the signal's note says how); none otherwise.

    The samples QA sees are in order by then, so the check below on ``diff(t)`` cannot see
    it: the import note is the evidence, and the repair is reported, never silent.
    """
    out = []
    for note in sig.notes:
        if TIME_REPAIRED in note:
            out.append(Finding(sig.name, Kind.RATE_IRREGULAR, t_start, t_end, Severity.ERROR,
                               f"time of {sig.name} goes backwards or repeats in the file: "
                               f"{note}", {"repaired_at_import": True}))
    return out


def check_signal(test: Test, sig: Signal, limits: dict | None = None,  # noqa: C901, PLR0912, PLR0915 - the level-1 checks of a signal in turn
                 opts: Level1Options | None = None, range_cache: dict | None = None,
                 test_span: tuple[float, float] | None = None) -> list[Finding]:
    """All level-1 findings of one signal.

    Parameters
    ----------
    test : Test
        The test (for partners of stuck detection).
    sig : Signal
        The signal to check.
    limits : dict, optional
        The vehicle's limits ``{base: (min, max)}`` in SI (``Vehicle.signal_limits()``).
    opts : Level1Options, optional
        Thresholds.
    range_cache : dict, optional
        Robust ranges of partner signals by name, shared within one run.
    test_span : (float, float), optional
        Start and end of the whole test [s] (default: ``test.span()``), for the
        too-few-samples check.
    """
    opts = opts or Level1Options()
    out: list[Finding] = []
    if test_span is None:
        test_span = test.span()
    parsed = _parse(sig.name)
    if parsed is None:
        out.append(Finding(sig.name, Kind.UNRECOGNISED, float(sig.time[0]) if sig.time.size else 0.0,
                           float(sig.time[-1]) if sig.time.size else 0.0, Severity.WARNING,
                           f"{sig.name} is not a name of the nomenclature; it cannot be checked "
                           "or used by the calculations", {}))
        return out
    base = parsed.base
    spec = registry()[base]
    v, t = sig.values, sig.time
    if v.size == 0:
        return [Finding(sig.name, Kind.ALL_ZERO, 0.0, 0.0, Severity.ERROR,
                        f"{sig.name} has no samples", {})]
    fin = np.isfinite(v)
    t_start, t_end = float(t[0]), float(t[-1])

    # time base ------------------------------------------------------------------------
    out.extend(_repaired_time_base(sig, t_start, t_end))
    if t.size > 2:
        dt = np.diff(t)
        med = float(np.median(dt))
        bad = dt <= 0
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            out.append(Finding(sig.name, Kind.RATE_IRREGULAR, float(t[i]), float(t[i + 1]),
                               Severity.ERROR, f"time of {sig.name} goes backwards or repeats "
                               f"{int(bad.sum())} times (first at {t[i]:.3f} s)",
                               {"count": int(bad.sum())}))
        if med > 0:
            gaps = runs(dt > opts.gap_factor * med)
            _emit_runs(out, sig, [(i0, i1 + 1) for i0, i1 in gaps], Kind.TIME_GAP, Severity.WARNING,
                       lambda i0, i1: (f"{sig.name} has no samples from {t[i0]:.1f} s to "
                                       f"{t[i1]:.1f} s (nominal period {med:.3g} s)"),
                       lambda i0, i1: {"gap_s": float(t[i1] - t[i0]), "period_s": med}, opts)
            jitter = float(np.std(dt[dt > 0]) / med) if (dt > 0).any() else 0.0
            if jitter > opts.jitter_info:
                out.append(Finding(sig.name, Kind.RATE_IRREGULAR, t_start, t_end, Severity.INFO,
                                   f"{sig.name} is sampled irregularly: period {med:.3g} s with "
                                   f"{100 * jitter:.0f} % jitter", {"period_s": med,
                                                                    "jitter_fraction": jitter}))

    # missing samples ----------------------------------------------------------------------
    if not fin.any():
        out.append(Finding(sig.name, Kind.NAN_GAP, t_start, t_end, Severity.ERROR,
                           f"{sig.name} has no valid sample (all NaN)", {"count": int(v.size)}))
        return out
    nan_runs = merge_runs(runs(~fin), t, 1.0)
    if nan_runs:
        period = sig.sample_period
        def nan_nums(i0, i1):
            return {"count": int((~fin[i0:i1 + 1]).sum()), "duration_s": float(t[i1] - t[i0])}
        long_r = [r for r in nan_runs if t[r[1]] - t[r[0]] >= max(1.0, 2 * period)]
        short_r = [r for r in nan_runs if r not in long_r]
        _emit_runs(out, sig, long_r, Kind.NAN_GAP, Severity.WARNING,
                   lambda i0, i1: f"{sig.name} is missing (NaN) from {t[i0]:.1f} s to {t[i1]:.1f} s",
                   nan_nums, opts)
        _emit_runs(out, sig, short_r, Kind.NAN_GAP, Severity.INFO,
                   lambda i0, i1: f"{sig.name} has isolated missing samples near {t[i0]:.1f} s",
                   nan_nums, opts)
    vf = v[fin]
    sparse = _sparse(sig, fin, test_span, opts)
    if sparse is not None:
        out.append(sparse)

    # range against the registry and the vehicle ------------------------------------------
    lo, hi = spec.range
    outside = fin & ((v < lo) | (v > hi))
    rs = merge_runs(runs(outside), t, 1.0)
    _emit_runs(out, sig, rs, Kind.RANGE, Severity.ERROR,
               lambda i0, i1: (f"{sig.name} reaches {_extreme(v, i0, i1, lo, hi):.6g} {sig.unit}, "
                               f"outside the plausible range [{lo:.6g}, {hi:.6g}] {sig.unit}"),
               lambda i0, i1: {"value": _extreme(v, i0, i1, lo, hi), "limit_min": lo, "limit_max": hi},
               opts)
    if limits and base in limits:
        vlo, vhi = limits[base]
        vlo = -np.inf if vlo is None else float(vlo)
        vhi = np.inf if vhi is None else float(vhi)
        scale = max(abs(x) for x in (vlo, vhi) if np.isfinite(x)) if np.isfinite([vlo, vhi]).any() else 0.0
        margin = opts.vehicle_limit_tolerance * scale
        over = fin & ~outside & ((v > vhi + margin) | (v < vlo - margin))
        rs = merge_runs(runs(over), t, 1.0)
        _emit_runs(out, sig, rs, Kind.VEHICLE_LIMIT, Severity.ERROR,
                   lambda i0, i1: (f"{sig.name} reaches {_extreme(v, i0, i1, vlo, vhi):.6g} {sig.unit}, "
                                   f"beyond the vehicle's limit [{vlo:.6g}, {vhi:.6g}] {sig.unit}"),
                   lambda i0, i1: {"value": _extreme(v, i0, i1, vlo, vhi), "limit_min": vlo,
                                   "limit_max": vhi}, opts)

    # all zero / constant -------------------------------------------------------------------
    qty = base.split("_")[1] if "_" in base else ""
    if np.all(vf == 0):
        sev = Severity.INFO if sig.resample == "previous" else Severity.ERROR
        out.append(Finding(sig.name, Kind.ALL_ZERO, t_start, t_end, sev,
                           f"{sig.name} is zero over the whole test: the channel was probably "
                           "not measured or not connected", {"samples": int(vf.size)}))
        return out
    if vf.size > 10 and np.all(vf == vf[0]):
        sev = Severity.WARNING if qty in DYNAMIC_QUANTITIES and sig.resample == "linear" else Severity.INFO
        out.append(Finding(sig.name, Kind.CONSTANT, t_start, t_end, sev,
                           f"{sig.name} is constant at {vf[0]:.6g} {sig.unit} over the whole test",
                           {"value": float(vf[0])}))
        return out

    # spikes (Hampel) -------------------------------------------------------------------
    sigma, resid = robust_noise(v, opts.spike_window)
    rrange = _robust_range(v)
    if sig.resample == "linear" and rrange > 0:
        thr = max(opts.spike_k * sigma, opts.spike_range_fraction * rrange)
        spikes = np.isfinite(resid) & (np.abs(resid) > thr)
        rs = [r for r in runs(spikes) if r[1] - r[0] < opts.spike_window // 2 + 1]
        # a spike leaves and returns: the samples just before and after it agree within
        # half its size; an edge followed by a decay (a current pulse as the engine
        # starts) does not return and is a transient, reported as info
        steps = []
        for i0, i1 in list(rs):
            if 0 < i0 and i1 + 1 < v.size:
                before, after = v[i0 - 1], v[i1 + 1]
                if np.isfinite(before) and np.isfinite(after) and \
                        abs(after - before) > 0.5 * abs(_peak(resid, i0, i1)):
                    steps.append((i0, i1))
                    rs.remove((i0, i1))
        rs = merge_runs(rs, t, 1.0)
        _emit_runs(out, sig, merge_runs(steps, t, 1.0), Kind.SPIKE, Severity.INFO,
                   lambda i0, i1: (f"{sig.name} jumps by {_peak(resid, i0, i1):+.4g} {sig.unit} at "
                                   f"{t[i0]:.1f} s and does not return to its previous level: a "
                                   f"transient, not a sensor spike"),
                   lambda i0, i1: {"deviation": _peak(resid, i0, i1), "threshold": thr}, opts)
        _emit_runs(out, sig, rs, Kind.SPIKE, Severity.WARNING,
                   lambda i0, i1: (f"{sig.name} has a spike of {_peak(resid, i0, i1):+.4g} {sig.unit} "
                                   f"at {t[i0]:.1f} s (threshold {thr:.3g} {sig.unit})"),
                   lambda i0, i1: {"value": float(v[i0 + int(np.nanargmax(np.abs(resid[i0:i1 + 1])))]),
                                   "deviation": _peak(resid, i0, i1), "threshold": thr}, opts,
                   cap=opts.max_spikes_corroborated)

    # impossible sign ---------------------------------------------------------------------
    if base in NON_NEGATIVE:
        vmax = float(np.max(np.abs(vf)))
        eps = max(1e-12, 1e-6 * vmax)
        neg = fin & (v < -eps)
        if neg.any():
            vmin = float(np.min(vf))
            beyond = -vmin > max(5 * sigma, 0.05 * vmax)
            sev = Severity.WARNING if beyond else Severity.INFO
            rs = merge_runs(runs(neg), t, 2.0)
            frac = float(neg.sum() / fin.sum())
            i0, i1 = rs[0][0], rs[-1][1]
            out.append(Finding(sig.name, Kind.NEGATIVE, float(t[i0]), float(t[i1]), sev,
                               f"{sig.name} is negative in {len(rs)} stretch(es) "
                               f"({100 * frac:.1f} % of samples, down to {vmin:.4g} {sig.unit})"
                               + ("; beyond the sensor noise" if beyond else "; within noise"),
                               {"value": vmin, "limit_min": 0.0, "fraction": frac,
                                "noise_sigma": sigma, "runs": len(rs)}))

    out.extend(_stuck(test, sig, base, opts, range_cache))
    return out


def _extreme(v: np.ndarray, i0: int, i1: int, lo: float, hi: float) -> float:
    seg = v[i0:i1 + 1]
    seg = seg[np.isfinite(seg)]
    if seg.size == 0:
        return float("nan")
    mx, mn = float(seg.max()), float(seg.min())
    return mx if (mx - hi) >= (lo - mn) else mn


def _peak(resid: np.ndarray, i0: int, i1: int) -> float:
    seg = resid[i0:i1 + 1]
    return float(seg[int(np.nanargmax(np.abs(seg)))])


#: Extra pairs whose simultaneous jumps reveal a physical event (not a sensor spike).
#: (power split: MG1 reacts the engine torque, so an engine-torque step moves the battery
#: current at once)
_EVENT_PARTNERS = (("ess_curr", "ess_volt"), ("eng_spd_target", "eng_spd_out"),
                   ("eng_trq_out", "ess_curr"),
                   ("mot_trq_out", "ess_curr"), ("mot_trq_out", "ess_volt"),
                   ("gen_trq_out", "ess_curr"), ("gen_trq_out", "ess_volt"),
                   ("eng_trq_out", "eng_spd_out"), ("ess_pwr", "ess_volt"))
#: Pairs where a fast change of the partner's level (not a spike of it) is the event: MG1
#: stopping or cranking the engine draws or returns battery power at once, while the engine
#: speed ramps (a ramp leaves no Hampel residual). Fraction of the partner's range that it
#: must move within one of its samples either side of the spike.
_STEP_PARTNERS = {("ess_curr", "eng_spd_out"): 0.05}


def _corroborate_spikes(test: Test, found: list[Finding], opts: Level1Options) -> None:
    """Demote to info the spikes that a related signal shows at the same time.

    A sensor spike is local to one channel; a jump seen at the same instant on a
    physically related channel (battery voltage sag with a current step, OBD torque and
    voltage in the same polling round) is a real event. The partner is looked at through
    the spiking signal's own sampling: it is interpolated at the spiking signal's sample
    times and the same Hampel residual is taken. So a 1 Hz OBD sample that "spikes" because
    1 Hz cannot follow a real transient is confirmed by a 10 Hz partner showing the same
    transient at 1 Hz, while a one-sample spike at 10 Hz cannot be confirmed by a 1 Hz
    partner (interpolated, it shows no jump). A partner at least as fast as the spiking signal
    is also looked at at its own rate within half a sample period of the spike (a 0.2 s
    motor-torque pulse caught by one 1 Hz OBD sample shows in the 10 Hz battery current
    between the OBD samples). To confirm, the partner's jump must exceed
    ``spike_corroboration_k`` of its noise and, relative to its range, be at least
    ``spike_corroboration_ratio`` of the spike's size relative to the signal's range (a real
    event moves the partner visibly: in the virtual tests a real 0.2 s engine-torque pulse
    moves the fuel rate by 10 % of the pulse's relative size, while a 3000 N spike on the
    tractive force coincides with wheel-torque transients of at most 1.5 %).
    """
    seen: dict[tuple[str, str], tuple[float, np.ndarray, float]] = {}
    ranges: dict[str, float] = {}

    def seen_by(sig: Signal | None, other: Signal) -> tuple[float, np.ndarray, float]:
        """Partner's (sigma, Hampel residual, range) at ``sig``'s times (None: its own)."""
        key = (sig.name if sig is not None else "", other.name)
        if key not in seen:
            x = other.at(sig.time, "linear") if sig is not None else other.values
            sigma, resid = robust_noise(x, opts.spike_window)
            seen[key] = (sigma, resid, _robust_range(x))
        return seen[key]

    def jumps(sigma: float, resid: np.ndarray, rng: float, sel: np.ndarray, rel_spike: float) -> bool:
        r = np.abs(resid[sel])
        r = r[np.isfinite(r)]
        return bool(r.size and rng > 0 and r.max() > opts.spike_corroboration_k * sigma
                    and r.max() / rng >= opts.spike_corroboration_ratio * rel_spike)

    for f in found:
        if f.kind != Kind.SPIKE or f.severity == Severity.INFO:
            continue
        sig = test[f.signal]
        p = _parse(sig.name)
        if sig.name not in ranges:
            ranges[sig.name] = _robust_range(sig.values)
        rel_spike = abs(f.numbers.get("deviation", np.nan)) / ranges[sig.name] \
            if ranges[sig.name] > 0 else np.nan
        partners = [ps for ps, _ in partners_of(test, sig.name)]
        for other in test:
            q = _parse(other.name)
            if q is None or q.origin != "test" or other.name == sig.name or p is None:
                continue
            if (p.base, q.base) in _EVENT_PARTNERS or (q.base, p.base) in _EVENT_PARTNERS:
                partners.append(other)
        if not np.isfinite(rel_spike):
            continue
        h = 0.5 * sig.sample_period
        sel = (sig.time >= f.start_s - h) & (sig.time <= f.end_s + h)
        for other in partners:
            real = jumps(*seen_by(sig, other), sel, rel_spike)
            if not real and other.sample_period <= 1.5 * sig.sample_period:
                # a partner at least as fast, at its own rate, within half a sample period
                own = (other.time >= f.start_s - h) & (other.time <= f.end_s + h)
                real = jumps(*seen_by(None, other), own, rel_spike)
            if real:
                f.severity = Severity.INFO
                f.message += f"; {other.name} jumps at the same time: a real transient, not a sensor spike"
                f.related.append(other.name)
                break
        if f.severity != Severity.INFO and p is not None:
            _corroborate_by_step(test, f, p.base, sig.sample_period)


def _corroborate_by_step(test: Test, f: Finding, base: str, period: float) -> None:
    """Demote a spike to info when a :data:`_STEP_PARTNERS` partner, sampled at least as fast,
    changes level by its fraction of range within one sample either side of the spike."""
    for other in test:
        q = _parse(other.name)
        frac = _STEP_PARTNERS.get((base, q.base)) if q is not None and q.origin == "test" else None
        if frac is None or other.sample_period > 1.5 * period:
            continue
        h = other.sample_period * 1.01
        moved, share = _moves(other, f.start_s - h, f.end_s + h, frac)
        if moved:
            f.severity = Severity.INFO
            f.message += (f"; {other.name} changes by {100 * share:.0f} % of its range at the "
                          "same time: a real transient (engine stop or start), not a sensor spike")
            f.related.append(other.name)
            return


def run_level1(test: Test, limits: dict | None = None,
               opts: Level1Options | None = None) -> list[Finding]:
    """Level-1 findings of every measured signal of a test (``_calc``/``_simu`` skipped)."""
    opts = opts or Level1Options()
    out: list[Finding] = []
    ranges: dict[str, float] = {}
    span = test.span()
    for sig in test:
        if sig.name.endswith("_calc") or sig.name.endswith("_simu"):
            continue
        out.extend(check_signal(test, sig, limits, opts, ranges, span))
    _corroborate_spikes(test, out, opts)
    return _cap_spikes(out, opts.max_findings_per_kind)


def _cap_spikes(found: list[Finding], cap: int) -> list[Finding]:
    """Merge the spikes of a signal beyond ``cap`` per severity into one finding (after each
    was judged: a sensor spike is never hidden among real transients)."""
    groups: dict[tuple[str, Severity], list[Finding]] = {}
    for f in found:
        if f.kind == Kind.SPIKE:
            groups.setdefault((f.signal, f.severity), []).append(f)
    drop: set[int] = set()
    for (name, sev), fs in groups.items():
        if len(fs) <= cap:
            continue
        tail = fs[cap - 1:]
        drop.update(id(f) for f in tail)
        merged = sum(int(f.numbers.get("runs_merged", 1)) for f in tail)
        s0, s1 = min(f.start_s for f in tail), max(f.end_s for f in tail)
        what = "real transients" if sev == Severity.INFO else "more spikes"
        found.append(Finding(name, Kind.SPIKE, s0, s1, sev,
                             f"{merged} more occurrences between {s0:.1f} s and {s1:.1f} s "
                             f"({what})", {**tail[0].numbers, "runs_merged": merged}))
    return [f for f in found if id(f) not in drop]


def corroborate_spikes_with_calc(test: Test, findings: list[Finding], computed: dict,
                                 agree: float = 0.5) -> None:
    """Demote to info the spikes that the signal's calculated counterpart reproduces.

    Run after the calculations: a spike on ``X`` whose ``X_calc`` (computed from other
    measured signals, never from ``X``) is within ``agree`` × the spike's deviation of the
    measured value at the spike instant is a real event (a generator speed swinging to
    -380 rad/s within one 1 Hz OBD sample as the engine stops, which the Willis equation
    gives from the engine and motor speeds); a sensor spike leaves its calculated value.
    """
    for f in findings:
        if f.kind != Kind.SPIKE or f.severity == Severity.INFO:
            continue
        p = _parse(f.signal)
        if p is None:
            continue
        cname = f"{p.base}_calc"
        info = computed.get(cname)
        if info is None or cname not in test or f.signal in info.get("inputs", {}).values():
            continue
        sig = test[f.signal]
        sel = (sig.time >= f.start_s - 1e-9) & (sig.time <= f.end_s + 1e-9)
        dev = abs(float(f.numbers.get("deviation", np.nan)))
        if not sel.any() or not dev > 0:
            continue
        diff = np.abs(sig.values[sel] - test[cname].at(sig.time[sel]))
        if np.isfinite(diff).all() and float(np.max(diff)) <= agree * dev:
            f.severity = Severity.INFO
            f.message += (f"; {cname} = {info.get('expr', '')} shows the same value "
                          f"(within {float(np.max(diff)):.3g} {sig.unit}): a real transient")
            f.related.append(cname)
