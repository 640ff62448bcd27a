"""Read the QA result (``findings.json`` structure) the way the report needs it.

The QA stage (:func:`vehval.qa.pipeline.run_qa`) produces a dict with top-level keys
``test``, ``alignment``, ``findings``, ``table2``, ``table3``, ``calculations``,
``selection`` and ``summary``. This module only reads it: it finds the signal names, time
spans and fit coefficients in each row, tolerating the key spellings below, so that the
report never has to guess a structure in several places.
"""

from __future__ import annotations

import math
from typing import Any, Iterable

SPAN_KEYS = (("t_start_s", "t_end_s"), ("start_s", "end_s"), ("t_start", "t_end"),
             ("t0_s", "t1_s"), ("t0", "t1"), ("start", "end"))
SLOPE_KEYS = ("slope", "fit_slope", "gain", "a1")
INTERCEPT_KEYS = ("intercept", "fit_intercept", "offset", "a0")
R2_KEYS = ("r2", "R2", "r_squared", "rsq")


def as_dict(qa: Any) -> dict:
    """The QA result as a plain dict (``QAResult.to_dict()``, a dict, or ``{}``)."""
    if qa is None:
        return {}
    if isinstance(qa, dict):
        return qa
    to_dict = getattr(qa, "to_dict", None)
    if callable(to_dict):
        return to_dict()
    raise TypeError(f"qa must be a dict, a QAResult or None, not {type(qa).__name__}")


def as_rows(obj: Any) -> list[dict]:
    """A list of row dicts from a list of dicts, ``{'rows': [...]}`` or ``{name: {...}}``."""
    if obj is None:
        return []
    if isinstance(obj, list):
        return [r for r in obj if isinstance(r, dict)]
    if isinstance(obj, dict):
        for k in ("rows", "items", "findings"):
            if isinstance(obj.get(k), list):
                return as_rows(obj[k])
        if obj and all(isinstance(v, dict) for v in obj.values()):
            return [{"name": k, **v} for k, v in obj.items()]
    return []


def first_number(row: dict, keys: Iterable[str]) -> float | None:
    """The first key of ``keys`` present in ``row`` with a finite number."""
    for k in keys:
        v = row.get(k)
        if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v):
            return float(v)
    return None


def signal_names_in(row: dict, names: Iterable[str]) -> list[str]:
    """Signal names of the test that appear as values of ``row`` (in key order).

    Values may be strings or lists of strings (``inputs``, ``signals``).
    """
    known = set(names)
    out: list[str] = []
    for v in row.values():
        items = v if isinstance(v, (list, tuple)) else [v]
        for item in items:
            if isinstance(item, str) and item in known and item not in out:
                out.append(item)
    return out


def finding_signal(row: dict, names: Iterable[str]) -> str | None:
    """The signal a QA1 finding is about."""
    for k in ("signal", "name", "channel"):
        if isinstance(row.get(k), str):
            return row[k]
    found = signal_names_in(row, names)
    return found[0] if found else None


def finding_spans(row: dict) -> list[tuple[float, float]]:
    """Time spans [s] a finding flags (``spans`` list or a start/end key pair)."""
    spans = row.get("spans") or row.get("intervals")
    out: list[tuple[float, float]] = []
    if isinstance(spans, list):
        for s in spans:
            if isinstance(s, dict):
                a = first_number(s, [p[0] for p in SPAN_KEYS])
                b = first_number(s, [p[1] for p in SPAN_KEYS])
            elif isinstance(s, (list, tuple)) and len(s) == 2:
                a, b = s
            else:
                continue
            if a is not None and b is not None:
                out.append((float(a), float(b)))
        return out
    for ka, kb in SPAN_KEYS:
        a, b = first_number(row, [ka]), first_number(row, [kb])
        if a is not None and b is not None:
            return [(a, b)]
    t = first_number(row, ("time_s", "t_s", "time"))
    return [(t, t)] if t is not None else []


def finding_range(row: dict) -> tuple[float, float] | None:
    """The plausible range [SI] a finding checked against, when it states one."""
    nums = row.get("numbers")
    if isinstance(nums, dict):
        inner = finding_range({k: v for k, v in nums.items()})
        if inner is not None:
            return inner
    for k in ("range", "limits", "bounds"):
        v = row.get(k)
        if isinstance(v, (list, tuple)) and len(v) == 2 and all(isinstance(x, (int, float)) for x in v):
            return float(v[0]), float(v[1])
    lo = first_number(row, ("limit_min", "min_allowed", "range_min", "lower", "lo"))
    hi = first_number(row, ("limit_max", "max_allowed", "range_max", "upper", "hi"))
    if lo is not None and hi is not None:
        return lo, hi
    return None


def severity(row: dict) -> str:
    """Severity label of a finding (``info`` when absent)."""
    for k in ("severity", "level", "status"):
        if isinstance(row.get(k), str):
            return row[k].lower()
    return "info"


def fit_of(row: dict) -> tuple[float | None, float | None, float | None]:
    """``(slope, intercept, r2)`` stated in a Table 2/3 row (None when absent)."""
    fit = row["fit"] if isinstance(row.get("fit"), dict) else row
    return (first_number(fit, SLOPE_KEYS), first_number(fit, INTERCEPT_KEYS),
            first_number(row, R2_KEYS) if first_number(fit, R2_KEYS) is None else first_number(fit, R2_KEYS))
