"""QA level 1: each signal alone.

Checks, per signal: plausible range (registry) and the vehicle's own limits, missing
samples (NaN) and holes in the time base, sample-rate irregularity, stuck segments,
constant or all-zero channels, spikes (Hampel filter) and impossible signs. The shape
checks and their corroboration by partner signals are in :mod:`vehval.qa.level1_shape`
(stuck segments) and :mod:`vehval.qa.level1_spikes` (spikes).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vehval.display import percent
from vehval.io.importer import TIME_REPAIRED
from vehval.nomenclature import registry
from vehval.qa.findings import Finding, Kind, Severity, merge_runs, message_units, runs
from vehval.qa.level1_shape import (
    DYNAMIC_QUANTITIES,
    NON_NEGATIVE,
    Level1Options,
    emit_runs,
    parse_name,
    robust_noise,
    stuck_findings,
)
from vehval.qa.level1_spikes import (
    cap_spikes,
    corroborate_spikes,
    corroborate_spikes_with_calc,
    spike_findings,
)
from vehval.test import Signal, Test

__all__ = ["Level1Options", "check_signal", "corroborate_spikes_with_calc", "robust_noise",
           "run_level1"]


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


def _sampling_findings(sig: Signal, opts: Level1Options) -> list[Finding]:
    """Time base of a signal: time going backwards or repeating, gaps, irregular sampling."""
    out: list[Finding] = []
    t = sig.time
    t_start, t_end = float(t[0]), float(t[-1])
    if t.size <= 2:
        return out
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
        emit_runs(out, sig, [(i0, i1 + 1) for i0, i1 in gaps], Kind.TIME_GAP, Severity.WARNING,
                   lambda i0, i1: (f"{sig.name} has no samples from {t[i0]:.1f} s to "
                                   f"{t[i1]:.1f} s (nominal period {med:.3g} s)"),
                   lambda i0, i1: {"gap_s": float(t[i1] - t[i0]), "period_s": med}, opts)
        jitter = float(np.std(dt[dt > 0]) / med) if (dt > 0).any() else 0.0
        if jitter > opts.jitter_info:
            out.append(Finding(sig.name, Kind.RATE_IRREGULAR, t_start, t_end, Severity.INFO,
                               f"{sig.name} is sampled irregularly: period {med:.3g} s with "
                               f"{percent(jitter, 0)} jitter", {"period_s": med,
                                                                "jitter_fraction": jitter}))
    return out


def _sign_findings(sig: Signal, fin: np.ndarray, sigma: float,
                   shown: Callable[[float], str]) -> list[Finding]:
    """Negative stretches of a signal that cannot be negative (beyond the noise ``sigma``:
    a warning; within it: information)."""
    v, t = sig.values, sig.time
    vf = v[fin]
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
        return [Finding(sig.name, Kind.NEGATIVE, float(t[i0]), float(t[i1]), sev,
                        f"{sig.name} is negative in {len(rs)} stretch(es) "
                        f"({percent(frac)} of samples, down to {shown(vmin)})"
                        + ("; beyond the sensor noise" if beyond else "; within noise"),
                        {"value": vmin, "limit_min": 0.0, "fraction": frac,
                         "noise_sigma": sigma, "runs": len(rs)})]
    return []


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
    parsed = parse_name(sig.name)
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
    out.extend(_sampling_findings(sig, opts))

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
        emit_runs(out, sig, long_r, Kind.NAN_GAP, Severity.WARNING,
                   lambda i0, i1: f"{sig.name} is missing (NaN) from {t[i0]:.1f} s to {t[i1]:.1f} s",
                   nan_nums, opts)
        emit_runs(out, sig, short_r, Kind.NAN_GAP, Severity.INFO,
                   lambda i0, i1: f"{sig.name} has isolated missing samples near {t[i0]:.1f} s",
                   nan_nums, opts)
    vf = v[fin]
    sparse = _sparse(sig, fin, test_span, opts)
    if sparse is not None:
        out.append(sparse)

    # range against the registry and the vehicle ------------------------------------------
    lo, hi = spec.range
    shown, shown_range = message_units(sig.name, sig.unit)
    outside = fin & ((v < lo) | (v > hi))
    rs = merge_runs(runs(outside), t, 1.0)
    emit_runs(out, sig, rs, Kind.RANGE, Severity.ERROR,
               lambda i0, i1: (f"{sig.name} reaches {shown(_extreme(v, i0, i1, lo, hi))}, "
                               f"outside the plausible range {shown_range(lo, hi)}"),
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
        emit_runs(out, sig, rs, Kind.VEHICLE_LIMIT, Severity.ERROR,
                   lambda i0, i1: (f"{sig.name} reaches {shown(_extreme(v, i0, i1, vlo, vhi))}, "
                                   f"beyond the vehicle's limit {shown_range(vlo, vhi)}"),
                   lambda i0, i1: {"value": _extreme(v, i0, i1, vlo, vhi), "limit_min": vlo,
                                   "limit_max": vhi}, opts)

    # all zero / constant -------------------------------------------------------------------
    qty = base.split("_")[1] if "_" in base else ""
    if np.all(vf == 0):
        sev = Severity.INFO if sig.resample == "previous" else Severity.ERROR
        out.append(Finding(sig.name, Kind.ALL_ZERO, t_start, t_end, sev,
                           f"{sig.name} is zero over the whole test: the channel was probably "
                           "not measured or not connected", {"samples": int(vf.size)},
                           fix=(f"{sig.raw_name or sig.name} holds no measurement in this test: "
                                "nothing can be computed from it; if the test did not measure "
                                "it, leave it out of this test's template, else check the "
                                "sensor and its connection")))
        return out
    if vf.size > 10 and np.all(vf == vf[0]):
        sev = Severity.WARNING if qty in DYNAMIC_QUANTITIES and sig.resample == "linear" else Severity.INFO
        out.append(Finding(sig.name, Kind.CONSTANT, t_start, t_end, sev,
                           f"{sig.name} is constant at {shown(float(vf[0]))} over the whole test",
                           {"value": float(vf[0])}))
        return out

    out.extend(spike_findings(sig, v, t, opts))
    sigma = robust_noise(v, opts.spike_window)[0]

    # impossible sign ---------------------------------------------------------------------
    if base in NON_NEGATIVE:
        out.extend(_sign_findings(sig, fin, sigma, shown))

    out.extend(stuck_findings(test, sig, opts, range_cache))
    return out


def _extreme(v: np.ndarray, i0: int, i1: int, lo: float, hi: float) -> float:
    seg = v[i0:i1 + 1]
    seg = seg[np.isfinite(seg)]
    if seg.size == 0:
        return float("nan")
    mx, mn = float(seg.max()), float(seg.min())
    return mx if (mx - hi) >= (lo - mn) else mn


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
    corroborate_spikes(test, out, opts)
    return cap_spikes(out, opts.max_findings_per_kind)


