"""QA level 1, the shape of a signal: stuck segments, the signal's resolution and noise,
and its partners (spikes, which share these, are :mod:`vehval.qa.level1_spikes`').

Both checks know the signal's resolution, inferred from the data (:func:`resolution`): a
deviation of a count or two of a quantised 1 Hz OBD value (0.1 V, 1 kPa, one SOC count) is
quantisation, not a spike; a slow signal (a battery temperature at 0.1 °C resolution) that
holds its value for a minute while it normally changes by less than a few counts in a
minute is not stuck.

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
from vehval.display import percent
from vehval.equations.engine_state import engine_running
from vehval.errors import SignalError
from vehval.nomenclature import registry
from vehval.qa.findings import Finding, Kind, Severity, message_units, runs
from vehval.qa.level2 import PER_INSTANCE, is_instance_qualifier
from vehval.test import Signal, Test

#: Base names that cannot be negative (beyond sensor noise).
NON_NEGATIVE = frozenset({"fuel_rate", "fuel_pwr", "fuel_mass", "fuel_energy", "brk_frc",
                          "brk_pwr", "brk_pres", "eng_spd_out"})
#: Quantity tokens of signals expected to vary during a drive (constant = suspicious).
DYNAMIC_QUANTITIES = frozenset({"spd", "trq", "frc", "acc", "pwr", "curr", "rate"})
#: Quantity tokens that respond within about 0.1-0.2 s (injection, machine torque, battery
#: current and power, engine load, pedal and throttle positions moved by a foot or an
#: actuator): sampled at 0.5 s or slower they can leave and return within a sample.
FAST_QUANTITIES = frozenset({"rate", "trq", "curr", "pwr", "load", "pos"})
#: Bases that respond as fast, whatever their quantity token (the intake manifold fills in
#: tens of milliseconds: its pressure follows the throttle and engine starts at once).
FAST_BASES = frozenset({"eng_pres_intake"})
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
    slow_sample_s: float = 0.5        # fast quantities sampled this slowly or slower: a
                                      # one-sample excursion inside their range may be real
    spike_quanta: float = 2.5         # a spike exceeds this many counts of the resolution
    spike_local_k: float = 5.0        # ... and this x the robust scatter of its neighbourhood
    spike_local_window: int = 21      # neighbourhood of that scatter [samples], odd
    stuck_quanta: float = 3.0         # a hold counts when the signal normally moves this
                                      # many counts of its resolution over the hold's duration


def parse_name(name: str):
    """The parsed name, or None when it is not in the nomenclature."""
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


def robust_range(v: np.ndarray) -> float:
    f = v[np.isfinite(v)]
    if f.size == 0:
        return 0.0
    lo, hi = np.percentile(f, [0.5, 99.5])
    return float(hi - lo)


def _span(sig: Signal, i0: int, i1: int) -> tuple[float, float]:
    return float(sig.time[i0]), float(sig.time[min(i1, sig.time.size - 1)])


def emit_runs(out: list[Finding], sig: Signal, rs: list[tuple[int, int]], kind: Kind,
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


def partners_of(test: Test, name: str, instances: bool = True) -> list[tuple[Signal, bool]]:
    """Signals expected to move with ``name``: ``(signal, is_duplicate)`` pairs.

    Numbered instances of a quantity (battery temperatures ``bt1``..``bt4``, module voltages
    ``m1``.., the 12 V supply at two points ``aux_volt`` / ``aux_volt_b2``) measure it at
    different places: with ``instances=False`` they are no partners (as in level 2: one may
    hold while another moves), otherwise they count as duplicates (all modules jump
    together in a real current transient).
    """
    p = parse_name(name)
    if p is None:
        return []
    out = []
    for other in test:
        if other.name == name:
            continue
        q = parse_name(other.name)
        if q is None or q.origin != "test":
            continue
        if q.base == p.base:
            if not instances and (is_instance_qualifier(p.source)
                                  or is_instance_qualifier(q.source) or p.base in PER_INSTANCE):
                continue      # another module, another sensor position: not a duplicate
            out.append((other, True))
        elif "target" in p.base or "target" in q.base:
            continue          # a target may legitimately hold while the actual value moves
        elif ((p.base, q.base) in CORRELATED_BASES or (q.base, p.base) in CORRELATED_BASES
              or (p.base, q.base) in _EXTRA_PARTNERS or (q.base, p.base) in _EXTRA_PARTNERS):
            out.append((other, False))
    return out


def moves(partner: Signal, t0: float, t1: float, frac: float,
           min_abs: float = 0.0, cache: dict | None = None) -> tuple[bool, float]:
    """Does ``partner`` vary within [t0, t1] by more than ``frac`` of its overall range
    (and more than ``min_abs``, e.g. a few quantisation steps of either signal)?

    The partner's movement is taken on its 5-sample rolling median within the span, so an
    isolated spike or dropout of the partner (a 0 V sentinel of an OBD voltage) is not a move.
    """
    full = cache.get(partner.name) if cache is not None else None
    if full is None:
        full = robust_range(partner.values)
        if cache is not None:
            cache[partner.name] = full
    if full <= 0:
        return False, 0.0
    sel = (partner.time >= t0) & (partner.time <= t1)
    seg = partner.values[sel]
    seg = seg[np.isfinite(seg)]
    if seg.size < 2:
        return False, 0.0
    if seg.size >= 5:
        seg = np.median(sliding_window_view(seg, 5), axis=1)
    rng = float(seg.max() - seg.min())
    return rng > max(frac * full, min_abs), rng / full


def _typical_change(v: np.ndarray, lag: int, i0: int, j1: int) -> float | None:
    """Median |v[k + lag] - v[k]| over the windows that do not overlap samples i0..j1 (how
    much the signal normally changes over ``lag`` samples); None when too few windows."""
    if lag < 1 or lag >= v.size:
        return None
    d = np.abs(v[lag:] - v[:-lag])
    k = np.arange(d.size)
    ok = np.isfinite(d) & ((k + lag < i0) | (k > j1))
    if ok.sum() < max(lag, 10):
        return None
    return float(np.median(d[ok]))


def _engine_running_span(test: Test, t0: float, t1: float, min_s: float,
                         min_samples: int) -> tuple[float, float] | None:
    """The part of [t0, t1] [s] over which an engine quantity is judged against its partners.

    ``(t0, t1)`` when no engine speed is measured or the engine runs at every sample of the
    span; else the longest stretch of consecutive samples at which the engine runs by the
    one engine-on rule (:mod:`vehval.equations.engine_state`), or None when no such stretch lasts ``min_s`` and
    ``min_samples`` (a hybrid's engine stopped, or only spinning down or cranking at the
    span's ends: its throttle holds whatever the pedal does).
    """
    best: tuple[float, float] | None = None
    for other in test:
        q = parse_name(other.name)
        if q is None or q.origin != "test" or q.base != "eng_spd_out":
            continue
        sel = (other.time >= t0) & (other.time <= t1) & np.isfinite(other.values)
        ts, seg = other.time[sel], other.values[sel]
        if seg.size < 2:
            continue
        run = engine_running(ts, np.abs(seg))
        if run.all():
            return t0, t1
        for i0, i1 in runs(run):
            if i1 - i0 + 1 >= min_samples and ts[i1] - ts[i0] >= min_s and (
                    best is None or ts[i1] - ts[i0] > best[1] - best[0]):
                best = (float(ts[i0]), float(ts[i1]))
        if best is None:
            return None
    return best if best is not None else (t0, t1)


def stuck_findings(test: Test, sig: Signal, opts: Level1Options,  # noqa: C901, PLR0912, PLR0915 - the stuck-signal exceptions (idle, saturation, held, slow) in turn
                   range_cache: dict | None = None) -> list[Finding]:
    """Stuck findings of one signal (exactly repeated value; see the module docstring).

    Quantisation-aware: a hold within 1.5 counts of zero is a zero; a duplicate partner must
    move by more than 3 counts of the coarser of the two resolutions; and a hold is not
    judged at all when the signal, elsewhere in the test, normally changes by less than
    ``stuck_quanta`` counts of its resolution over the hold's duration (a battery temperature
    at 0.1 °C holding for a minute while it rises 0.1 °C a minute).
    """
    v, t = sig.values, sig.time
    if v.size < opts.stuck_min_samples or sig.resample == "previous":
        return []
    shown = message_units(sig.name, sig.unit)[0]
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
    span = robust_range(v)
    zero_tol = 0.01 * span
    in_cand = np.zeros(v.size - 1, bool)
    for i0, j1 in cand:
        in_cand[i0:j1] = True
    moving = np.isfinite(np.diff(v)) & (np.abs(v[:-1]) > zero_tol) & ~in_cand
    repeat_frac = int((same & moving).sum()) / max(1, int(moving.sum()))
    covered = cand_len / max(1, v.size - 1)
    noisy = repeat_frac < opts.noisy_repeat_fraction and covered < 0.5
    partners = partners_of(test, sig.name, instances=False)
    if any(dup for _, dup in partners):
        partners = [(p, dup) for p, dup in partners if dup]
    nz = np.abs(np.diff(v))
    nz = nz[np.isfinite(nz) & (nz > 0)]
    quantum = float(np.median(nz)) if nz.size else 0.0
    res = resolution(v)
    p_res = {p.name: resolution(p.values) for p, dup in partners if dup}
    is_engine = sig.name.startswith("eng_")
    found: list[Finding] = []
    for i0, j1 in sorted(cand, key=lambda r: r[0] - r[1])[:50]:
        value = float(v[i0])
        if (abs(value) <= zero_tol and not noisy) or abs(value) <= 1.5 * res:
            value = 0.0          # quantised "zero" (e.g. -1e-6 kg/s at fuel cut) counts as zero
        t0, t1 = float(t[i0]), float(t[j1])
        typical = _typical_change(v, j1 - i0, i0, j1) if res > 0 else None
        if typical is not None and typical < opts.stuck_quanta * res:
            continue             # a slow signal at its resolution: holding is its normal way
        mover = None
        span_run: tuple[float, float] | None = (t0, t1)
        if is_engine:            # an engine quantity holds while the engine is stopped
            span_run = _engine_running_span(test, t0, t1, opts.stuck_min_s,
                                            opts.stuck_min_samples)
        for psig, dup in partners:
            if value == 0 and not dup:
                continue
            a, b = t0, t1
            if not dup:
                if span_run is None:
                    continue
                a, b = span_run
            min_abs = 3 * max(quantum, p_res.get(psig.name, 0.0)) if dup else 0.0
            ok, frac = moves(psig, a, b, opts.partner_move_fraction if dup
                              else opts.correlated_move_fraction, min_abs, range_cache)
            if ok and value == 0:
                pv = psig.values[(psig.time >= t0) & (psig.time <= t1)]
                ok = bool(np.nanmedian(np.abs(pv)) > 0.1 * max(robust_range(psig.values), 1e-12))
            if ok:
                mover = (psig, dup, frac)
                if dup:
                    break
        if value == 0 and mover is None:
            continue
        if mover is not None:
            psig, dup, frac = mover
            sev = Severity.ERROR if dup else Severity.WARNING
            msg = (f"{sig.name} stays exactly at {shown(float(v[i0]))} for {t1 - t0:.1f} s "
                   f"while {psig.name} varies by {percent(frac, 0)} of its range")
            nums = {"value": value, "duration_s": t1 - t0, "samples": j1 - i0 + 1,
                    "partner_range_fraction": frac}
            found.append(Finding(sig.name, Kind.STUCK, t0, t1, sev, msg, nums,
                                 related=[psig.name]))
        elif noisy and abs(value) > 1e-3 * span and span_run is not None:
            # (a hold within 0.1 % of the range from zero, such as a 0.001 mph roll creep at
            # standstill, is a standstill when no partner says otherwise)
            msg = (f"{sig.name} repeats exactly {shown(float(v[i0]))} for {t1 - t0:.1f} s "
                   f"although it changes at almost every sample elsewhere (stuck sensor?)")
            found.append(Finding(sig.name, Kind.STUCK, t0, t1, Severity.WARNING, msg,
                                 {"value": value, "duration_s": t1 - t0,
                                  "samples": j1 - i0 + 1, "repeat_fraction": repeat_frac}))
    found.sort(key=lambda f: f.start_s)
    return found[:opts.max_findings_per_kind]


def resolution(values: np.ndarray) -> float:
    """Resolution of a quantised signal, inferred from its successive steps [its unit].

    The smallest recurring step (the third smallest non-zero step, float noise of the unit
    conversion left out, so one or two odd steps do not set it) is the count; the signal is quantised when at least 80 % of its
    steps are within a quarter count of a whole number of counts (a thermistor table's
    slightly unequal counts, 0.098-0.109 °C, pass). 0 for a continuous signal.
    """
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if v.size < 10:
        return 0.0
    d = np.abs(np.diff(v))
    d = d[d > 1e-9 * max(float(np.max(np.abs(v))), 1e-300)]
    if d.size < 10:
        return 0.0
    q = float(np.partition(d, 2)[2])
    k = d / q
    on_grid = np.abs(k - np.round(k)) <= 0.25
    return q if float(on_grid.mean()) >= 0.8 else 0.0


def raw_quantum(sig: Signal, values: np.ndarray) -> float:
    """The last decimal place the file's raw numbers show, in the signal's unit [its unit].

    A signal with too few steps for :func:`resolution` (a barometric pressure toggling 99 /
    100 kPa) still tells its count by its raw numbers: all whole kPa (as SAE J1979 encodes
    PID 0x33) cannot resolve less than 1 kPa. The raw numbers are rebuilt from the unit
    conversion; 0 when they do not sit on a grid of 1, 0.1, 0.01 or 0.001 raw units.
    """
    from vehval.units import conversion

    try:
        scale, off = conversion(sig.raw_unit or "", sig.unit)
    except Exception:  # noqa: BLE001 - a unit that does not convert back is not judged
        return 0.0
    if not scale:
        return 0.0
    raw = (np.asarray(values, float) - off) / scale
    raw = raw[np.isfinite(raw)]
    if raw.size < 10:
        return 0.0
    for step in (1.0, 0.1, 0.01, 0.001):
        k = raw / step
        if np.all(np.abs(k - np.round(k)) <= 1e-6 * np.maximum(1.0, np.abs(k))):
            return step * abs(scale)
    return 0.0
