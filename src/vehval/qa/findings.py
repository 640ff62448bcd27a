"""QA findings: one dataclass for every problem the analysis reports.

A finding names the signal, the kind of problem, the time span, a severity, a plain
sentence and the numbers behind it. Findings serialise to plain dicts (``findings.json``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Callable, Iterable

import numpy as np

from vehval.jsonsafe import clean


class Severity(str, Enum):
    """How serious a finding is: ``info`` (worth knowing), ``warning`` (check it),
    ``error`` (the signal is wrong where the finding applies)."""

    INFO = "info"
    WARNING = "warning"
    ERROR = "error"

    @property
    def rank(self) -> int:
        return {"info": 0, "warning": 1, "error": 2}[self.value]


class Kind(str, Enum):
    """Kinds of findings, by QA level."""

    # level 1: each signal alone
    RANGE = "range"                      # outside the registry's plausible range
    VEHICLE_LIMIT = "vehicle_limit"      # beyond the vehicle's published limit
    NAN_GAP = "nan_gap"                  # missing samples (NaN)
    TIME_GAP = "time_gap"                # hole in the time base
    RATE_IRREGULAR = "rate_irregular"    # sample period jitter / non-monotonic time
    STUCK = "stuck"                      # exactly repeated value while it should move
    CONSTANT = "constant"                # the whole channel is one value
    SPIKE = "spike"                      # isolated outlier samples
    NEGATIVE = "negative"                # impossible sign
    ALL_ZERO = "all_zero"                # the whole channel is zero
    UNRECOGNISED = "unrecognised"        # name not in the nomenclature
    SPARSE = "sparse"                    # too few samples for the test's duration
    # level 2: the same quantity from several sources
    LOW_AGREEMENT = "low_agreement"
    GAIN = "gain"
    OFFSET = "offset"
    SIGN_FLIP = "sign_flip"
    UNIT = "unit"
    LAG = "lag"
    # alignment
    ALIGNMENT = "alignment"
    # level 3: measured vs calculated
    CALC_MISMATCH = "calc_mismatch"
    FUEL_MAP = "fuel_map"                # fuel meter against the engine fuel map
    UNIT_SUSPECT = "unit_suspect"        # physics points at a wrong unit in the template
    FUEL_EFFICIENCY = "fuel_efficiency"  # fuel energy against the work the engine can give
    FUEL_RESPONSE = "fuel_response"      # fuel zero/missing/flat while the engine delivers
    # results stage (level 4): results and their inputs
    RESULTS = "results"                  # a result cannot be given or needs attention
    DRIVE_QUALITY = "drive_quality"      # driver outside the SAE J2951 tolerances


LEVEL_OF_KIND = {
    **{k: 1 for k in (Kind.RANGE, Kind.VEHICLE_LIMIT, Kind.NAN_GAP, Kind.TIME_GAP,
                      Kind.RATE_IRREGULAR, Kind.STUCK, Kind.CONSTANT, Kind.SPIKE,
                      Kind.NEGATIVE, Kind.ALL_ZERO, Kind.UNRECOGNISED, Kind.SPARSE)},
    **{k: 2 for k in (Kind.LOW_AGREEMENT, Kind.GAIN, Kind.OFFSET, Kind.SIGN_FLIP,
                      Kind.UNIT, Kind.LAG)},
    Kind.ALIGNMENT: 0,
    Kind.CALC_MISMATCH: 3,
    Kind.FUEL_MAP: 3,
    Kind.UNIT_SUSPECT: 3,
    Kind.FUEL_EFFICIENCY: 3,
    Kind.FUEL_RESPONSE: 3,
    Kind.RESULTS: 4,
    Kind.DRIVE_QUALITY: 4,
}


@dataclass
class Finding:
    """One QA finding.

    Attributes
    ----------
    signal : str
        Full signal name the finding applies to.
    kind : Kind
        What kind of problem.
    start_s, end_s : float
        Time span [s] where it applies (test time, after alignment).
    severity : Severity
        ``info``, ``warning`` or ``error``.
    message : str
        One plain sentence for a person.
    numbers : dict
        The numbers behind it (e.g. ``value``, ``limit``, ``count``), SI units.
    level : int
        QA level (0 alignment, 1, 2, 3; 4 the results stage).
    related : list of str
        Other signals involved (the other source, the calculated signal...).
    fix : str
        What to do about it, in one line (e.g. "declare fuel_rate_test in g/s, not
        mg/s (x1000)"); empty when there is nothing specific to say.
    """

    signal: str
    kind: Kind
    start_s: float
    end_s: float
    severity: Severity
    message: str
    numbers: dict = field(default_factory=dict)
    level: int = 1
    related: list[str] = field(default_factory=list)
    fix: str = ""

    def __post_init__(self) -> None:
        self.kind = Kind(self.kind)
        self.severity = Severity(self.severity)
        self.level = LEVEL_OF_KIND.get(self.kind, self.level)

    def overlaps(self, start_s: float, end_s: float) -> bool:
        """True when the finding's span overlaps ``[start_s, end_s]`` [s]."""
        return self.start_s <= end_s and start_s <= self.end_s

    def to_dict(self) -> dict:
        out = {
            "signal": self.signal,
            "kind": self.kind.value,
            "level": self.level,
            "severity": self.severity.value,
            "start_s": clean(self.start_s),
            "end_s": clean(self.end_s),
            "message": self.message,
            "numbers": clean(self.numbers),
            "related": list(self.related),
        }
        if self.fix:                     # optional key: only when there is a fix to name
            out["fix"] = self.fix
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "Finding":
        return cls(signal=d["signal"], kind=Kind(d["kind"]), start_s=d["start_s"],
                   end_s=d["end_s"], severity=Severity(d["severity"]), message=d["message"],
                   numbers=dict(d.get("numbers", {})), level=d.get("level", 1),
                   related=list(d.get("related", [])), fix=str(d.get("fix", "")))


def message_units(signal: str, si_unit: str) -> tuple[Callable[[float], str],
                                                      Callable[[float, float], str]]:
    """Formatters for a finding's sentence: a value and a range of ``signal`` in the
    display units people read (:mod:`vehval.display`); ``numbers`` stay SI."""
    from vehval.display import format_range, format_value

    return (lambda x: format_value(x, si_unit, signal=signal),
            lambda lo, hi: format_range(lo, hi, si_unit, signal=signal))


def delta_units(signal: str, si_unit: str) -> Callable[..., str]:
    """Formatter of a difference, step or threshold of ``signal`` in its display unit."""
    from vehval.display import format_delta

    return lambda x, signed=False: format_delta(x, si_unit, signal=signal, signed=signed)


def summarise(findings: Iterable[Finding]) -> dict:
    """Counts by severity, by kind and by level (every severity key always present)."""
    by_sev = {s.value: 0 for s in Severity}
    by_kind: dict[str, int] = {}
    by_level: dict[str, int] = {}
    n = 0
    for f in findings:
        n += 1
        by_sev[f.severity.value] += 1
        by_kind[f.kind.value] = by_kind.get(f.kind.value, 0) + 1
        by_level[str(f.level)] = by_level.get(str(f.level), 0) + 1
    return {"total": n, "by_severity": by_sev, "by_kind": dict(sorted(by_kind.items())),
            "by_level": dict(sorted(by_level.items()))}


def worst(findings: Iterable[Finding], signal: str | None = None) -> Severity | None:
    """Highest severity among findings (of one signal if given), or ``None``."""
    best: Severity | None = None
    for f in findings:
        if signal is not None and f.signal != signal:
            continue
        if best is None or f.severity.rank > best.rank:
            best = f.severity
    return best


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges ``(i0, i1)`` (inclusive) of consecutive ``True`` in a boolean array."""
    m = np.asarray(mask, bool)
    if m.size == 0 or not m.any():
        return []
    d = np.diff(m.astype(np.int8), prepend=0, append=0)
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1) - 1
    return list(zip(starts.tolist(), ends.tolist()))


def merge_runs(rs: list[tuple[int, int]], time: np.ndarray, gap_s: float) -> list[tuple[int, int]]:
    """Merge index runs separated by less than ``gap_s`` [s]."""
    out: list[tuple[int, int]] = []
    for i0, i1 in rs:
        if out and time[i0] - time[out[-1][1]] <= gap_s:
            out[-1] = (out[-1][0], i1)
        else:
            out.append((i0, i1))
    return out


def untrusted_mask(names: set[str] | frozenset[str], times: np.ndarray, findings: Iterable[Finding],
                   pad_s: float = 0.5) -> np.ndarray:
    """Samples at ``times`` [s] covered (±``pad_s``) by a warning or error of any of ``names``.

    A finding that summarises several separate stretches (``numbers["runs"] > 1``, e.g. "negative
    in 4 stretches" from the first to the last) does not mark the time between them; the
    stretches themselves carry their own range or spike findings.
    """
    bad = np.zeros(np.asarray(times).size, bool)
    for f in findings:
        if (f.numbers or {}).get("runs", 1) > 1:
            continue
        if f.signal in names and f.severity != Severity.INFO:
            bad |= (times >= f.start_s - pad_s) & (times <= f.end_s + pad_s)
    return bad
