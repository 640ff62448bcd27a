"""Signal selection: keep one trusted signal per quantity, with a reason for every decision.

Rules (SAE 2006-01-0667, section "signal selection"), applied in this order:

1. user overrides from the template's ``selection`` section (``keep`` forces a signal in,
   ``drop`` removes it with the user's reason);
2. names outside the nomenclature are dropped;
3. signals with a disqualifying finding are dropped: all zero, all NaN, constant dynamic
   quantity, stuck against a duplicate, sign flip, wrong unit, gain error, out of range
   over more than 10 % of the test (or on more than 10 % of its samples), a single sample;
4. when several sources measure the same quantity, the preferred source is kept (facility
   sensor without qualifier, then facility qualifiers, then OBD/CAN) if they agree; if they
   disagree, the one closer to the calculated signal (QA3) or with fewer warnings wins;
5. consistency: on a power split, the kept engine/motor/generator speeds must satisfy
   Willis; a slower (OBD) speed that breaks it in transients while the ``_calc`` one from
   the others is available is dropped.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeGuard

import numpy as np

from vehval.display import percent
from vehval.errors import SignalError
from vehval.nomenclature import preference_rank, registry
from vehval.qa.findings import Finding, Kind, Severity
from vehval.qa.level2 import PairComparison
from vehval.qa.level3 import CalcComparison
from vehval.test import Test

DISQUALIFYING = {Kind.ALL_ZERO, Kind.SIGN_FLIP, Kind.UNIT, Kind.UNRECOGNISED}


@dataclass
class Selection:
    """Selection decisions: ``kept`` and ``dropped`` map full names to a reason.

    ``kept`` is QA's choice as every later stage takes it:
    ``test.best(base, kept=selection.kept)`` (:meth:`vehval.test.Test.best`, the one
    selection rule) returns the kept source of ``base``.
    """

    kept: dict[str, str] = field(default_factory=dict)
    dropped: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"kept": dict(sorted(self.kept.items())), "dropped": dict(sorted(self.dropped.items()))}


def _disqualified(sig_name: str, findings: list[Finding], duration: float) -> str | None:
    range_s = 0.0
    for f in findings:
        if f.signal != sig_name:
            continue
        if f.kind in DISQUALIFYING and f.severity != Severity.INFO:
            return f"{f.kind.value}: {f.message}"
        if f.kind == Kind.NAN_GAP and f.severity == Severity.ERROR:
            return f"{f.kind.value}: {f.message}"
        if f.kind == Kind.CONSTANT and f.severity == Severity.WARNING:
            return f"{f.kind.value}: {f.message}"
        if f.kind == Kind.STUCK and f.severity == Severity.ERROR:
            return f"{f.kind.value}: {f.message}"
        if f.kind == Kind.GAIN and f.severity == Severity.ERROR:
            return f"{f.kind.value}: {f.message}"
        if f.kind == Kind.RANGE and f.severity == Severity.ERROR and "fraction" in f.numbers:
            return f"{f.kind.value}: {f.message}"
        if f.kind == Kind.SPARSE and f.severity == Severity.ERROR:
            return f"{f.kind.value}: {f.message}"
        if f.kind in (Kind.RANGE, Kind.VEHICLE_LIMIT):
            range_s += max(f.end_s - f.start_s, 0.0)
    if duration > 0 and range_s > 0.1 * duration:
        return f"out of range over {100 * range_s / duration:.0f} % of the test"
    return None


def _sparse(sig_name: str, findings: list[Finding]) -> bool:
    return any(f.signal == sig_name and f.kind == Kind.SPARSE for f in findings)


def _warnings(sig_name: str, findings: list[Finding]) -> int:
    return sum(1 for f in findings if f.signal == sig_name and f.severity != Severity.INFO)


def _calc_score(row: CalcComparison) -> float:
    """Agreement with the calculation: R² penalised by the relative mean difference."""
    rel = row.rel_diff if row.rel_diff is not None and np.isfinite(row.rel_diff) else 1.0
    return float(row.r2) - 2.0 * rel


def _agree(row: PairComparison | None) -> TypeGuard[PairComparison]:
    return (row is not None and row.r2 is not None and np.isfinite(row.r2) and row.r2 >= 0.95
            and np.isfinite(row.gain) and abs(row.gain - 1) <= 0.05)


def select_signals(test: Test, findings: list[Finding], table2: Sequence[PairComparison] = (),
                   table3: Sequence[CalcComparison] = (), user_keep: Sequence[str] = (),
                   user_drop: dict[str, str] | None = None,
                   parameters: dict[str, float] | None = None) -> Selection:
    """Decide which measured signals to keep.

    Parameters
    ----------
    test : Test
        Aligned test (with its ``_calc`` signals).
    findings : list of Finding
        Findings of alignment, QA1, QA2 and QA3.
    table2, table3 : list
        Level-2 and level-3 comparison rows.
    user_keep, user_drop : optional
        The template's ``selection.keep`` and ``selection.drop``.
    parameters : dict, optional
        Calculation parameters (``ring_teeth``, ``sun_teeth``) for the Willis check.

    Returns
    -------
    Selection
        Every measured signal is either kept or dropped, with a reason.
    """
    user_drop = dict(user_drop or {})
    sel = Selection()
    reg = registry()
    groups: dict[str, list[str]] = {}
    t0, t1 = test.span()
    duration = t1 - t0
    for sig in test:
        if sig.name.endswith("_calc") or sig.name.endswith("_simu"):
            continue
        if sig.name in user_drop:
            sel.dropped[sig.name] = f"dropped by the user: {user_drop[sig.name]}"
            continue
        if sig.name in user_keep:
            sel.kept[sig.name] = "kept by the user (template selection.keep)"
            continue
        try:
            p = reg.parse(sig.name)
        except SignalError:
            sel.dropped[sig.name] = "not a name of the nomenclature (unrecognised signal)"
            continue
        why = _disqualified(sig.name, findings, duration)
        if why:
            sel.dropped[sig.name] = why
            continue
        groups.setdefault(p.base, []).append(sig.name)
    rows2 = {(r.ref, r.other): r for r in table2}
    rows2.update({(r.other, r.ref): r for r in table2})
    r3 = {}
    for r in table3:
        if r.r2 is not None and np.isfinite(r.r2):
            r3[r.measured] = r
    for base, names in groups.items():
        forced = [n for n in user_keep if n in test and reg.parse(n).base == base]
        names = sorted(names, key=preference_rank)
        # a source with too few samples for the test is never preferred over a complete one
        complete = [n for n in names if not _sparse(n, findings)]
        if complete and len(complete) < len(names):
            for n in names:
                if n not in complete and not forced:
                    sel.dropped[n] = (f"too few samples for the test; {complete[0]} covers "
                                      f"{base} better")
            names = complete
        if forced:
            for n in names:
                sel.dropped[n] = f"the user keeps {forced[0]} for {base}"
            continue
        if len(names) == 1:
            sel.kept[names[0]] = f"only usable source of {base}"
            continue
        best = names[0]
        reason = f"preferred source of {base} (facility sensor first)"
        # disagreeing sources: the one closer to the calculation, else fewer warnings
        if any(not _agree(rows2.get((best, n))) for n in names[1:]):
            scored = [(n, _calc_score(r3[n]) if n in r3 else None, _warnings(n, findings))
                      for n in names]
            with_calc = [(n, c, w) for n, c, w in scored if c is not None]
            if len(with_calc) >= 2:
                cand = max(with_calc, key=lambda s: (s[1], -preference_rank(s[0])[0]))
                if cand[0] != best and cand[1] > (_calc_score(r3[best]) if best in r3 else -9) + 0.02:
                    best = cand[0]
                    reason = (f"agrees best with {r3[best].calculated} (R² {r3[best].r2:.3f}, mean "
                              f"difference {percent(r3[best].rel_diff)} of range) among "
                              f"disagreeing sources of {base}")
            else:
                fewest = min(scored, key=lambda s: (s[2], preference_rank(s[0])))
                if fewest[2] < scored[0][2]:
                    best = fewest[0]
                    reason = f"fewest QA warnings among disagreeing sources of {base}"
        sel.kept[best] = reason
        for n in names:
            if n == best:
                continue
            row = rows2.get((best, n))
            if _agree(row):
                sel.dropped[n] = f"duplicate of {best} (R² {row.r2:.3f}, gain {row.gain:.3f}); {best} preferred"
            elif row is not None:
                sel.dropped[n] = (f"disagrees with {best} (R² {row.r2:.3f}, gain {row.gain:.3f}); "
                                  f"{best} kept: {reason}")
            else:
                sel.dropped[n] = f"{best} preferred for {base} (no overlap to compare)"
    _willis_consistency(test, sel, parameters or {})
    return sel


def _willis_consistency(test: Test, sel: Selection, params: dict) -> None:
    """Drop a slower machine speed that breaks Willis when a ``_calc`` replacement exists."""
    nr, ns = params.get("ring_teeth"), params.get("sun_teeth")
    if not nr or not ns:
        return
    reg = registry()
    kept = {}
    for n in sel.kept:
        try:
            b = reg.parse(n).base
        except SignalError:
            continue
        if b in ("eng_spd_out", "mot_spd_out", "gen_spd_out"):
            kept[b] = n
    if len(kept) < 3:
        return
    sigs = {b: test[n] for b, n in kept.items()}
    fast = min(sigs.values(), key=lambda s: s.sample_period)
    grid = fast.time
    e, m, g = (sigs[b].at(grid) for b in ("eng_spd_out", "mot_spd_out", "gen_spd_out"))
    resid = e * (nr + ns) - m * nr - g * ns
    ok = np.isfinite(resid)
    if ok.sum() < 10:
        return
    scale = np.nanpercentile(np.abs(e * (nr + ns)), 99) or 1.0
    rms = float(np.sqrt(np.mean(resid[ok] ** 2)) / scale)
    if rms < 0.03:
        return
    slow = max(sigs.values(), key=lambda s: s.sample_period)
    b = reg.parse(slow.name).base
    if slow.sample_period > 1.5 * fast.sample_period and f"{b}_calc" in test:
        del sel.kept[slow.name]
        sel.dropped[slow.name] = (f"breaks the Willis equation with the other kept speeds in "
                                  f"transients (RMS residual {percent(rms)} of the engine-side "
                                  f"term, slower sampling); use {b}_calc")


def save_final_template(template: Any, selection: Selection, path: str | Path) -> Path:
    """Write ``template`` with its ``selection`` section filled (atomic), for the next tests.

    The user's own ``keep`` list is preserved; ``drop`` receives every dropped signal with
    its reason (the user's reasons are kept as written).
    """
    from vehval.io.template import Selection as TemplateSelection

    user = template.selection
    drop = {}
    for name, reason in sorted(selection.dropped.items()):
        prefix = "dropped by the user: "
        drop[name] = user.drop.get(name, reason[len(prefix):] if reason.startswith(prefix) else reason)
    for name, reason in user.drop.items():  # dropped at import: never reached the selection
        drop.setdefault(name, reason)
    drop = dict(sorted(drop.items()))
    final = template.model_copy(update={"selection": TemplateSelection(keep=list(user.keep), drop=drop)})
    return final.save(path)
