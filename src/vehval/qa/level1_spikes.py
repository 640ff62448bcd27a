"""QA level 1, spikes: a sample that leaves its neighbours by more than the signal's noise
and resolution allow, unless a partner signal jumps with it (a physical event, not a sensor
fault) or the calculated quantities corroborate it.

The signal's resolution is inferred from the data (:func:`resolution`): a deviation of a
count or two of a quantised 1 Hz OBD value (0.1 V, 1 kPa, one SOC count) is quantisation,
not a spike. Stuck segments are :mod:`vehval.qa.level1_shape`'s.
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from vehval.display import percent
from vehval.qa.findings import Finding, Kind, Severity, delta_units, merge_runs, runs
from vehval.qa.level1_shape import (
    FAST_BASES,
    FAST_QUANTITIES,
    Level1Options,
    emit_runs,
    moves,
    parse_name,
    partners_of,
    raw_quantum,
    resolution,
    robust_noise,
    robust_range,
)
from vehval.test import Signal, Test


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


def corroborate_spikes(test: Test, found: list[Finding], opts: Level1Options) -> None:
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
            seen[key] = (sigma, resid, robust_range(x))
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
        p = parse_name(sig.name)
        if sig.name not in ranges:
            ranges[sig.name] = robust_range(sig.values)
        rel_spike = abs(f.numbers.get("deviation", np.nan)) / ranges[sig.name] \
            if ranges[sig.name] > 0 else np.nan
        partners = [ps for ps, _ in partners_of(test, sig.name)]
        for other in test:
            q = parse_name(other.name)
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
        q = parse_name(other.name)
        frac = _STEP_PARTNERS.get((base, q.base)) if q is not None and q.origin == "test" else None
        if frac is None or other.sample_period > 1.5 * period:
            continue
        h = other.sample_period * 1.01
        moved, share = moves(other, f.start_s - h, f.end_s + h, frac)
        if moved:
            f.severity = Severity.INFO
            f.message += (f"; {other.name} changes by {percent(share, 0)} of its range at the "
                          "same time: a real transient (engine stop or start), not a sensor spike")
            f.related.append(other.name)
            return


def _local_scatter(resid: np.ndarray, window: int) -> np.ndarray:
    """Robust scatter (1.4826 x median |residual|) of each sample's neighbourhood."""
    a = np.abs(resid)
    out = np.full(a.shape, np.nan)
    h = window // 2
    if a.size < window:
        return out
    with warnings.catch_warnings():       # an all-NaN neighbourhood gives NaN: not judged
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(sliding_window_view(a, window), axis=1)
    out[h:a.size - h] = 1.4826 * med
    return out


def spike_findings(sig: Signal, v: np.ndarray, t: np.ndarray,
                   opts: Level1Options) -> list[Finding]:
    """Spike findings of one signal (Hampel filter, quantisation- and scatter-aware).

    A sample is a spike when its residual from the rolling median (window ``spike_window``)
    exceeds the largest of: ``spike_k`` robust sigmas of the whole signal,
    ``spike_range_fraction`` of its robust range, ``spike_quanta`` counts of its resolution
    (rounding puts up to half a count on the sample and on the median, a slow real change one
    more count within the window: up to 2 counts are quantisation), and ``spike_local_k``
    times the robust scatter of the residuals in its neighbourhood (``spike_local_window``):
    a sample that departs from its neighbours no more than they do from theirs is not an
    outlier (a 1 Hz point sample of a pulsating injector flow).
    """
    delta = delta_units(sig.name, sig.unit)
    out: list[Finding] = []
    sigma, resid = robust_noise(v, opts.spike_window)
    rrange = robust_range(v)
    if sig.resample != "linear" or not rrange > 0:
        return out
    q = resolution(v) or raw_quantum(sig, v)
    thr = max(opts.spike_k * sigma, opts.spike_range_fraction * rrange, opts.spike_quanta * q)
    with np.errstate(invalid="ignore"):
        local = opts.spike_local_k * _local_scatter(resid, opts.spike_local_window)
        spikes = np.isfinite(resid) & (np.abs(resid) > thr) & ~(np.abs(resid) <= local)
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
    # a fast quantity sampled slowly (a 1 Hz point sample of a pulsating fuel flow) may
    # leave and return within one sample for real: inside the signal's own range (its
    # 0.5-99.5 % band widened by half its width: the test's one hardest tip-in is the top of
    # the band), that is not evidence of a sensor fault
    p = parse_name(sig.name)
    qty = p.base.split("_")[1] if p is not None and "_" in p.base else ""
    band = np.nanpercentile(v, [0.5, 99.5]) if np.isfinite(v).any() else np.full(2, np.nan)
    band = band + np.array([-0.5, 0.5]) * (band[1] - band[0])
    slow = []
    fast = qty in FAST_QUANTITIES or (p is not None and p.base in FAST_BASES)
    if fast and sig.sample_period >= opts.slow_sample_s:
        for i0, i1 in list(rs):
            seg = v[i0:i1 + 1]
            if np.all((seg >= band[0]) & (seg <= band[1])):
                slow.append((i0, i1))
                rs.remove((i0, i1))
    rs = merge_runs(rs, t, 1.0)
    emit_runs(out, sig, merge_runs(slow, t, 1.0), Kind.SPIKE, Severity.INFO,
              lambda i0, i1: (f"{sig.name} departs by {delta(_peak(resid, i0, i1), signed=True)} at "
                              f"{t[i0]:.1f} s for one sample and returns, within its own range: "
                              f"sampled every {sig.sample_period:.3g} s, a quantity that changes "
                              f"within 0.2 s can do that for real; not judged a sensor spike"),
              lambda i0, i1: {"deviation": _peak(resid, i0, i1), "threshold": thr,
                              "period_s": sig.sample_period}, opts)
    emit_runs(out, sig, merge_runs(steps, t, 1.0), Kind.SPIKE, Severity.INFO,
              lambda i0, i1: (f"{sig.name} jumps by {delta(_peak(resid, i0, i1), signed=True)} at "
                              f"{t[i0]:.1f} s and does not return to its previous level: a "
                              f"transient, not a sensor spike"),
              lambda i0, i1: {"deviation": _peak(resid, i0, i1), "threshold": thr}, opts)
    emit_runs(out, sig, rs, Kind.SPIKE, Severity.WARNING,
              lambda i0, i1: (f"{sig.name} has a spike of {delta(_peak(resid, i0, i1), signed=True)} "
                              f"at {t[i0]:.1f} s (threshold {delta(thr)})"),
              lambda i0, i1: {"value": float(v[i0 + int(np.nanargmax(np.abs(resid[i0:i1 + 1])))]),
                              "deviation": _peak(resid, i0, i1), "threshold": thr}, opts,
              cap=opts.max_spikes_corroborated)
    return out


def cap_spikes(found: list[Finding], cap: int) -> list[Finding]:
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
        p = parse_name(f.signal)
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
                          f"(within {delta_units(sig.name, sig.unit)(float(np.max(diff)))}): a real transient")
            f.related.append(cname)
