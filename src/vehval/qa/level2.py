"""QA level 2: the same quantity measured by several sources (Table 2 of SAE 2006-01-0667).

For every base name measured by two or more signals, each pair is compared at the slower
signal's own sample times (the faster one is interpolated): R², mean absolute difference,
mean relative difference, linear fit ``other = slope · ref + offset`` and the residual lag
left after alignment. Poor agreement becomes findings: a gain error, an offset, a sign
flip, a wrong unit (the slope is a known unit factor), a residual lag or plain low
correlation. With three or more sources the finding goes to the signal that agrees least
with the others; with two, to the less preferred source (facility sensor preferred).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vehval.align import estimate_pair
from vehval.constants import MILE_M, RPM_RAD_PER_S
from vehval.errors import SignalError
from vehval.jsonsafe import finite_or_none
from vehval.nomenclature import preference_rank, registry
from vehval.qa.findings import Finding, Kind, Severity, delta_units, untrusted_mask
from vehval.qa.uncertainty import Accuracies, pair_uncertainty
from vehval.test import Signal, Test

#: Unit factors a wrong unit typically produces (slope of other vs ref).
UNIT_FACTORS: dict[str, float] = {
    "rpm vs rad/s": RPM_RAD_PER_S, "mph vs m/s": 0.44704, "km/h vs m/s": 1 / 3.6,
    "kilo (x1000)": 1000.0, "g vs kg": 1e-3, "lb vs kg": 0.45359237, "lbf vs N": 4.4482216,
    "percent vs fraction": 100.0, "mph vs km/h": MILE_M / 1000.0, "degree vs rad": np.pi / 180,
    "lbf·ft vs N·m": 1.3558179,
}

#: The SI units each unit factor can occur in (None: any unit); a pedal position [1] at
#: 1.6 x another is not an mph vs km/h mix-up.
UNIT_FACTOR_UNITS: dict[str, frozenset[str] | None] = {
    "rpm vs rad/s": frozenset({"rad/s"}), "mph vs m/s": frozenset({"m/s", "m/s**2"}),
    "km/h vs m/s": frozenset({"m/s", "m/s**2"}), "kilo (x1000)": None,
    "g vs kg": frozenset({"kg", "kg/s"}), "lb vs kg": frozenset({"kg", "kg/s"}),
    "lbf vs N": frozenset({"N"}), "percent vs fraction": frozenset({"dimensionless", ""}),
    "mph vs km/h": frozenset({"m/s", "m/s**2"}), "degree vs rad": frozenset({"rad", "rad/s"}),
    "lbf·ft vs N·m": frozenset({"N*m", "N·m"}),
}

#: Bases measured per instance (module, cell...): different qualifiers are not duplicates.
#: ``diag_count``: warm-ups, distance and time since codes cleared are three counters.
PER_INSTANCE = frozenset({"ess_volt_module", "ess_res_module", "diag_count"})


def is_instance_qualifier(q: str | None) -> bool:
    """``m1``, ``bt3``, ``d12``: a numbered instance (module, sensor), not a source."""
    return bool(q) and re.fullmatch(r"[a-z]+\d+", q or "") is not None


@dataclass
class Level2Options:
    r2_min: float = 0.9             # below: low agreement (warning) ...
    low_agreement_diff: float = 0.05  # ... if also mean |diff| > this x reference range
    gain_tol: float = 0.05          # |slope - 1| above: gain warning
    gain_error: float = 0.2         # above: error
    offset_tol: float = 0.05        # |offset| above this x reference range: offset warning
    unit_tol: float = 0.03          # slope within this of a unit factor: wrong unit
    lag_min_s: float = 0.2          # residual lag threshold floor [s]
    lag_search_s: float = 5.0
    max_all_pairs: int = 5          # more sources: compare each with the preferred one only
    en_max: float = 1.0             # |En| of the mean difference above: beyond the accuracies


@dataclass
class PairComparison:
    """One row of Table 2."""

    base: str
    ref: str
    other: str
    n: int
    r2: float
    r: float
    mean_abs_diff: float
    mean_rel_diff: float
    slope: float
    offset: float
    gain: float
    residual_lag_s: float
    mean_diff: float
    ref_range: float
    unit: str
    start_s: float = float("nan")
    end_s: float = float("nan")
    slow_period_s: float = float("nan")
    notes: list[str] = field(default_factory=list)
    # cumulative uncertainty (vehval.qa.uncertainty): mean of ref over the compared samples,
    # expanded U (k = 2) of each side's mean [unit], En of mean_diff, each side's accuracy
    mean_ref: float = float("nan")
    u_ref: float = float("nan")
    u_other: float = float("nan")
    en: float = float("nan")
    accuracy: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {k: finite_or_none(v) for k, v in self.__dict__.items()}


def compare_pair(ref: Signal, other: Signal, opts: Level2Options | None = None,
                 findings_before: list[Finding] | None = None) -> PairComparison | None:
    """Table-2 metrics of ``other`` against ``ref`` (``None`` when they do not overlap).

    Metrics (at the slower signal's sample times, NaN excluded): ``r2`` = squared Pearson
    correlation; ``mean_abs_diff`` = mean |other − ref| [unit]; ``mean_rel_diff`` =
    mean |other − ref| / mean |ref|; ``slope``, ``offset`` of the least-squares line
    ``other = slope · ref + offset``; ``residual_lag_s`` [s] = offset still found by
    cross-correlation (positive: other is late). Samples where either signal has a level-1
    warning or error (a spike, an out-of-range stretch; ``findings_before``) are left out
    unless that leaves less than half of them.
    """
    opts = opts or Level2Options()
    base = registry().parse(ref.name).base
    slow_other = other.sample_period >= ref.sample_period
    if slow_other:
        t = other.time
        b = other.values
        a = ref.at(t)
    else:
        t = ref.time
        a = ref.values
        b = other.at(t)
    ok = np.isfinite(a) & np.isfinite(b)
    if findings_before:
        bad = untrusted_mask({ref.name, other.name}, t, findings_before)
        if bad.any() and (ok & ~bad).sum() >= 0.5 * ok.sum():
            ok &= ~bad
    if ok.sum() < 5:
        return None
    a, b, tt = a[ok], b[ok], t[ok]
    da, db = a - a.mean(), b - b.mean()
    saa, sbb = float((da * da).sum()), float((db * db).sum())
    r = float((da * db).sum() / np.sqrt(saa * sbb)) if saa > 0 and sbb > 0 else float("nan")
    slope = float((da * db).sum() / saa) if saa > 0 else float("nan")
    # gain robust to noise in both signals (regression dilution): reduced-major-axis slope,
    # or the ratio of means for offset-dominated signals (e.g. a pack voltage)
    gain = float(np.sign(r) * np.sqrt(sbb / saa)) if saa > 0 and np.isfinite(r) else float("nan")
    if abs(a.mean()) > 2 * a.std() and abs(a.mean()) > 0:
        gain = float(b.mean() / a.mean())
    offset = float(b.mean() - slope * a.mean()) if np.isfinite(slope) else float("nan")
    mad = float(np.mean(np.abs(b - a)))
    mean_ref = float(np.mean(np.abs(a)))
    lo, hi = np.percentile(a, [0.5, 99.5])
    lag = float("nan")
    pr = estimate_pair(ref, other, opts.lag_search_s, kind="residual", refine=False) \
        if np.isfinite(r) and abs(r) > 0.5 else None
    if pr is not None:
        lag = -pr.offset_s   # other late by `lag` => shift needed is -lag
    return PairComparison(base=base, ref=ref.name, other=other.name, n=int(ok.sum()),
                          r2=r * r if np.isfinite(r) else float("nan"), r=r,
                          mean_abs_diff=mad, mean_rel_diff=mad / mean_ref if mean_ref > 0 else float("nan"),
                          slope=slope, offset=offset, gain=gain, residual_lag_s=lag,
                          mean_diff=float(np.mean(b - a)),
                          ref_range=float(hi - lo), unit=ref.unit,
                          start_s=float(tt[0]), end_s=float(tt[-1]),
                          slow_period_s=float(max(ref.sample_period, other.sample_period)),
                          mean_ref=float(np.mean(a)))


def _findings_for(row: PairComparison, blamed: str, other_name: str, ref_period: float,
                  opts: Level2Options) -> list[Finding]:
    out: list[Finding] = []
    rel = [other_name]
    s0, s1 = row.start_s, row.end_s
    nums = {"r2": row.r2, "slope": row.slope, "offset": row.offset,
            "gain": row.gain, "mean_abs_diff": row.mean_abs_diff, "mean_rel_diff": row.mean_rel_diff,
            "residual_lag_s": row.residual_lag_s}
    r, slope = row.r, row.gain
    if not np.isfinite(r):
        return out
    if slope < 0 and r < -0.8:
        out.append(Finding(blamed, Kind.SIGN_FLIP, s0, s1, Severity.ERROR,
                           f"{row.other} is the mirror image of {row.ref} (slope {slope:.3g}, "
                           f"r {r:.3f}): sign convention flipped", nums, related=rel))
        return out
    if abs(r) >= 0.8 and slope > 0:
        for label, fac in UNIT_FACTORS.items():
            units = UNIT_FACTOR_UNITS.get(label)
            if units is not None and row.unit not in units:
                continue
            for f in (fac, 1 / fac):
                if abs(slope / f - 1) < opts.unit_tol and abs(f - 1) > 0.1:
                    out.append(Finding(blamed, Kind.UNIT, s0, s1, Severity.ERROR,
                                       f"{row.other} is {slope:.4g} x {row.ref}: looks like a unit "
                                       f"error ({label})", {**nums, "factor": f}, related=rel))
                    return out
        # a ratio of means away from 1 with a well-determined fitted slope of 1 is an offset
        # (two pedal tracks 15 % apart by design), not a gain
        offset_only = row.r2 >= 0.9 and abs(row.slope - 1) <= opts.gain_tol
        if abs(slope - 1) > opts.gain_tol and not offset_only:
            sev = Severity.ERROR if abs(slope - 1) > opts.gain_error else Severity.WARNING
            out.append(Finding(blamed, Kind.GAIN, s0, s1, sev,
                               f"{row.other} reads {slope:.3f} x {row.ref} (fit slope {row.slope:.3f}, "
                               f"offset {delta_units(row.ref, row.unit)(row.offset, signed=True)}): gain differs by "
                               f"{100 * (slope - 1):+.1f} %", nums, related=rel))
        elif row.ref_range > 0 and abs(row.mean_diff) > opts.offset_tol * row.ref_range:
            out.append(Finding(blamed, Kind.OFFSET, s0, s1, Severity.WARNING,
                               f"{row.other} is offset from {row.ref} by {delta_units(row.ref, row.unit)(row.mean_diff, signed=True)} "
                               f"on average ({100 * abs(row.mean_diff) / row.ref_range:.0f} % of its range)",
                               nums, related=rel))
    if not out and np.isfinite(row.en) and abs(row.en) > opts.en_max:
        out.append(_beyond_accuracy(row, blamed, nums, rel))
    if (row.r2 < opts.r2_min and not any(f.kind in (Kind.UNIT, Kind.GAIN) for f in out)
            and row.mean_abs_diff > opts.low_agreement_diff * row.ref_range):
        out.append(Finding(blamed, Kind.LOW_AGREEMENT, s0, s1, Severity.WARNING,
                           f"{row.other} and {row.ref} agree poorly (R² {row.r2:.3f}, mean "
                           f"difference {delta_units(row.ref, row.unit)(row.mean_abs_diff)})", nums, related=rel))
    lag_thr = max(opts.lag_min_s, 1.5 * ref_period, 0.5 * row.slow_period_s)
    if np.isfinite(row.residual_lag_s) and abs(row.residual_lag_s) > lag_thr and row.r2 > 0.5:
        out.append(Finding(blamed, Kind.LAG, s0, s1, Severity.WARNING,
                           f"{row.other} lags {row.ref} by {row.residual_lag_s:+.2f} s after alignment",
                           nums, related=rel))
    return out


def _beyond_accuracy(row: PairComparison, blamed: str, nums: dict, rel: list[str]) -> Finding:
    """An offset finding: the two means differ by more than their combined accuracy."""
    fmt = delta_units(row.ref, row.unit)
    assumed = [n for n, a in row.accuracy.items() if a.get("assumed")]
    return Finding(
        blamed, Kind.OFFSET, row.start_s, row.end_s, Severity.WARNING,
        f"{row.other} differs from {row.ref} by {fmt(row.mean_diff, signed=True)} on average, "
        f"beyond their combined accuracy (En {row.en:+.2f}; U {fmt(row.u_other)} and "
        f"{fmt(row.u_ref)}, k = 2"
        + (f"; assumed class accuracy of {', '.join(assumed)}" if assumed else "") + ")",
        {**nums, "mean_diff": row.mean_diff, "en": row.en, "u_ref": row.u_ref,
         "u_other": row.u_other}, related=rel)


def run_level2(test: Test, opts: Level2Options | None = None,
               findings_before: list[Finding] | None = None,
               accuracy: Mapping[str, Any] | None = None
               ) -> tuple[list[PairComparison], list[Finding]]:
    """Table 2 (every pair of measured signals of the same base name) and its findings.

    ``findings_before`` (level-1 findings): samples under a warning or error of either
    signal of a pair are left out of its comparison (see :func:`compare_pair`).
    ``accuracy`` (template ``accuracy:``, signal -> ``AccuracySpec``): each side's accuracy
    for the row's En (:mod:`vehval.qa.uncertainty`; undeclared: the class default).
    """
    opts = opts or Level2Options()
    acc = Accuracies(accuracy)
    reg = registry()
    groups: dict[str, list[Signal]] = {}
    for sig in test:
        try:
            p = reg.parse(sig.name)
        except SignalError:
            continue
        if p.origin == "test" and not is_instance_qualifier(p.source) and p.base not in PER_INSTANCE:
            groups.setdefault(p.base, []).append(sig)
    rows: list[PairComparison] = []
    findings: list[Finding] = []
    for base, sigs in sorted(groups.items()):
        if len(sigs) < 2:
            continue
        sigs = sorted(sigs, key=lambda s: preference_rank(s.name))
        pair_rows = []
        for i in range(len(sigs) if len(sigs) <= opts.max_all_pairs else 1):
            for j in range(i + 1, len(sigs)):
                row = compare_pair(sigs[i], sigs[j], opts, findings_before)
                if row is not None:
                    pair_uncertainty(row, acc)
                    pair_rows.append((sigs[i], sigs[j], row))
                    rows.append(row)
        score: dict[str, list[float]] = {s.name: [] for s in sigs}
        for a, b, row in pair_rows:
            agree = row.r2 if np.isfinite(row.r2) and row.gain > 0 else 0.0
            agree *= 1.0 / (1.0 + abs(np.log(abs(row.gain)))) if np.isfinite(row.gain) and row.gain > 0 else 0.0
            score[a.name].append(agree)
            score[b.name].append(agree)
        mean_score = {k: (np.mean(v) if v else 0.0) for k, v in score.items()}
        for a, b, row in pair_rows:
            if len(sigs) >= 3 and mean_score[a.name] < mean_score[b.name] - 1e-9:
                blamed, other = a.name, b.name
            else:
                blamed, other = b.name, a.name
            findings.extend(_findings_for(row, blamed, other, a.sample_period, opts))
    return rows, findings
