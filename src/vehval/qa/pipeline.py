"""The QA pipeline: alignment -> QA1 -> QA2 -> calculation -> QA3 -> selection.

:func:`run_qa` returns a :class:`QAResult` whose :meth:`QAResult.to_dict` is the content of
``findings.json`` (contract in docs/qa.md) and whose ``validated`` test holds the aligned,
selected measured signals plus the ``_calc`` signals.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import Any

from vehval import align as _align
from vehval.equations.calc import CalcResult, compute
from vehval.errors import ConfigError
from vehval.qa.findings import Finding, Kind, Severity, summarise
from vehval.qa.fuelmap import FuelMapOptions, fuel_map_check
from vehval.qa.level1 import Level1Options, corroborate_spikes_with_calc, run_level1
from vehval.qa.level2 import Level2Options, PairComparison, run_level2
from vehval.qa.level3 import CalcComparison, Level3Options, run_checks, run_level3
from vehval.qa.plausibility import run_plausibility
from vehval.qa.select import Selection, select_signals
from vehval.test import Test

#: Version of the findings.json contract (bump on any incompatible change).
FINDINGS_VERSION = 1


@dataclass
class QAResult:
    """Everything the QA found and decided for one test."""

    test_id: str
    files: list[str]
    duration_s: float
    alignment: list[_align.AlignmentResult]
    findings: list[Finding]
    table2: list[PairComparison]
    table3: list[CalcComparison]
    calculations: CalcResult
    selection: Selection
    validated: Test
    notes: list[str] = field(default_factory=list)
    signals_in: int = 0
    checks: list[dict] = field(default_factory=list)

    def to_dict(self) -> dict:
        """The ``findings.json`` document (stable top-level keys, see docs/qa.md)."""
        return {
            "findings_version": FINDINGS_VERSION,
            "test": {"id": self.test_id, "files": list(self.files),
                     "duration_s": round(float(self.duration_s), 6)},
            "alignment": [a.to_dict() for a in self.alignment],
            "findings": [f.to_dict() for f in sorted(
                self.findings, key=lambda f: (-f.severity.rank, f.level, f.signal, f.start_s))],
            "table2": [r.to_dict() for r in self.table2],
            "table3": [r.to_dict() for r in self.table3],
            "checks": list(self.checks),
            "calculations": self.calculations.to_dict(),
            "selection": self.selection.to_dict(),
            "summary": {**summarise(self.findings),
                        "signals_in": self.signals_in,
                        "kept": len(self.selection.kept), "dropped": len(self.selection.dropped),
                        "computed": len(self.calculations.computed)},
            "notes": list(self.notes),
        }


def _strength(f: Finding) -> float:
    """Size of a level-3 disagreement relative to the measured signal's range."""
    if f.kind == Kind.SIGN_FLIP:
        return float("inf")
    n = f.numbers
    rng = n.get("test_range") or 0.0
    for key in ("drift", "max_deviation", "mean_abs_diff"):
        v = n.get(key)
        if v is not None and rng and rng > 0:
            return abs(float(v)) / float(rng)
    return 0.0


def _blame_inputs(level3: list[Finding], earlier: list[Finding], computed: dict) -> None:
    """Measured-versus-calculated findings (mismatch, drift) that an input explains are
    demoted to info, naming the input.

    An input explains a finding when it has its own warning/error at levels 1-2 over the
    finding's span (unless those samples were already left out of the comparison), or its
    own level-3 finding, unless the two explain each other (each is an input of the
    other's calculation: the torque balance rearranged) and the finding is the larger one
    relative to its signal's range. The inputs are followed through intermediate
    ``_calc`` signals.
    """
    from vehval.qa.level3 import measured_inputs
    kinds = (Kind.CALC_MISMATCH, Kind.OFFSET)
    active = [g for g in level3 if g.severity != Severity.INFO
              and g.kind in kinds + (Kind.SIGN_FLIP,) and g.related]
    inputs_of = {id(g): measured_inputs(g.related[0], computed) if g.related[0].endswith("_calc")
                 else set(g.related[1:]) for g in active}
    demote: list[tuple[Finding, list[str]]] = []
    for f in active:
        if f.kind not in kinds:
            continue
        ins = inputs_of[id(f)] | set(f.related[1:])
        skip_earlier = bool(f.numbers.get("input_findings_excluded"))
        bad = {g.signal for g in earlier if g.signal in ins and g.severity != Severity.INFO
               and not skip_earlier and g.overlaps(f.start_s, f.end_s)}
        for g in active:
            if g is f or g.signal not in ins or g.signal == f.signal:
                continue
            mutual = f.signal in inputs_of[id(g)]
            if not mutual or _strength(g) > _strength(f):
                bad.add(g.signal)
        if bad:
            demote.append((f, sorted(bad)))
    for f, names in demote:
        f.severity = Severity.INFO
        f.message += f" (inputs with their own findings: {', '.join(names)})"


def _blame_check_inputs(check_findings: list[Finding], earlier: list[Finding]) -> None:
    """A failed balance check blames its usual suspect only when no other measured input
    of the balance has a warning or error of its own."""
    for f in check_findings:
        others = set(f.related) - {f.signal}
        bad = sorted({g.signal for g in earlier if g.signal in others
                      and g.severity != Severity.INFO})
        if bad:
            f.severity = Severity.INFO
            f.message += f" (other inputs have their own findings: {', '.join(bad)})"


def _vehicle_limits(vehicle: Any) -> dict | None:
    if vehicle is None or not hasattr(vehicle, "signal_limits"):
        return None
    return vehicle.signal_limits()


def _validated_test(work: Test, selection, calc, vehicle, calc_set, constants, bad: set[str],
                    notes: list[str], architecture: str | None = None) -> Test:
    """The kept measured signals plus calculations that rest only on kept signals.

    A calculation that used a signal the selection dropped (e.g. a battery current found
    sign-flipped only by a later check) is recomputed without it, or left out.
    """
    dropped = set(selection.dropped)
    from vehval.qa.level3 import measured_inputs
    tainted = sorted(n for n in calc.computed if measured_inputs(n, calc.computed) & dropped)
    validated = Test(meta=copy.deepcopy(work.meta))
    for sig in work:
        if sig.name in selection.kept:
            validated.add(sig)
    if not tainted:
        for sig in work:
            if sig.name.endswith("_calc"):
                validated.add(sig)
        return validated
    redo = compute(validated, vehicle, calc_set, constants,  # only kept signals are in it
                   architecture=architecture)
    lost = sorted(set(calc.computed) - set(redo.computed))
    notes.append(
        f"calculations recomputed without the dropped signals ({', '.join(sorted(dropped))}) "
        f"because {', '.join(tainted)} used them"
        + (f"; no longer computable: {', '.join(lost)}" if lost else ""))
    return validated


def run_qa(test: Test, vehicle: Any = None, template: Any = None,  # noqa: PLR0913 - the options of every QA level, passed through
           pairs: list[tuple[str, str]] | None = None, *, max_offset_s: float = 30.0,
           align: bool = True, calc_set: str | None = None,
           level1: Level1Options | None = None, level2: Level2Options | None = None,
           level3: Level3Options | None = None, fuel_map: FuelMapOptions | None = None
           ) -> QAResult:
    """Run the whole data-quality analysis on one imported test.

    Parameters
    ----------
    test : Test
        Imported test (not modified: the pipeline works on a copy).
    vehicle : Vehicle, optional
        For the vehicle's limits (``signal_limits()``) and calculation parameters.
    template : Template, optional
        For the constants (when not already in ``test.meta.constants``) and the user's
        ``selection`` overrides.
    pairs : list of (str, str), optional
        Alignment pairs named by the user.
    max_offset_s : float
        Alignment search range ±[s].
    align : bool
        Estimate and remove clock offsets between sources.
    calc_set : str, optional
        Calculation set name or path (default by vehicle/signals).
    level1, level2, level3, fuel_map : options, optional
        Thresholds of each stage (defaults documented in docs/qa.md).

    Returns
    -------
    QAResult
    """
    if not (math.isfinite(max_offset_s) and max_offset_s >= 0):
        raise ConfigError(f"max offset {max_offset_s!r} s: the alignment search range must be "
                          "a finite number >= 0 s (--max-offset)")
    work = Test([copy.copy(s) for s in test], meta=copy.deepcopy(test.meta))
    # repairs made at import that change the data (a stray timestamp dropped) stay visible
    notes: list[str] = [n for n in test.meta.notes if n.startswith("warning")]
    constants = dict(work.meta.constants)
    if template is not None and hasattr(template, "constants_dict"):
        for k, v in template.constants_dict().items():
            constants.setdefault(k, v)
    user_keep = list(getattr(getattr(template, "selection", None), "keep", []) or [])
    user_drop = dict(getattr(getattr(template, "selection", None), "drop", {}) or {})

    findings: list[Finding] = []
    alignment: list[_align.AlignmentResult] = []
    if align and len([s for s in work.sources if s not in ("calc", "simu")]) > 1:
        alignment = _align.align_test(work, pairs, max_offset_s=max_offset_s)
        for a in alignment:
            if not a.applied:
                sig = a.pairs[0].other if a.pairs else f"source:{a.source}"
                t0, t1 = work.span()
                findings.append(Finding(sig, Kind.ALIGNMENT, t0, t1, Severity.WARNING,
                                        f"source '{a.source}' not aligned to '{a.reference}': {a.message}",
                                        {"offset_s": a.offset_s, "confidence": a.confidence}))
    findings += run_level1(work, _vehicle_limits(vehicle), level1)
    declared = dict(getattr(template, "accuracy", None) or {})
    table2, f2 = run_level2(work, level2, findings, declared)
    findings += f2
    # inputs not to trust in the calculations
    bad = {f.signal for f in findings if f.severity == Severity.ERROR} | set(user_drop)
    # the tested car's architecture: no engine, fuel or hybrid relation on a battery-electric car
    from vehval.vehicle.definition import architecture_of

    arch = architecture_of(vehicle, template)
    calc = compute(work, vehicle, calc_set, constants, exclude=bad, architecture=arch)
    corroborate_spikes_with_calc(work, findings, calc.computed)
    table3, f3 = run_level3(work, calc, level3, findings, declared)
    checks, fc = run_checks(work, calc)
    _blame_inputs(f3, findings, calc.computed)
    _blame_check_inputs(fc, findings + f3)
    findings += f3 + fc
    fuel_rows, ff = fuel_map_check(work, vehicle, findings, calc.computed, fuel_map)
    checks += fuel_rows
    findings += ff
    findings += run_plausibility(work, table3, template, vehicle)
    pvals = {k: v["value"] for k, v in calc.parameters.items() if v.get("value") is not None}
    selection = select_signals(work, findings, table2, table3, user_keep, user_drop, pvals)
    validated = _validated_test(work, selection, calc, vehicle, calc_set, constants, bad, notes,
                                arch)
    validated.meta.notes = list(validated.meta.notes) + [
        f"QA: kept {len(selection.kept)} measured signals, dropped {len(selection.dropped)}, "
        f"computed {len(calc.computed)}"]
    t0, t1 = test.span()
    return QAResult(test_id=test.meta.test_id, files=list(test.meta.files), duration_s=t1 - t0,
                    alignment=alignment, findings=findings, table2=table2, table3=table3,
                    calculations=calc, selection=selection, validated=validated, notes=notes,
                    signals_in=len(test), checks=checks)
