"""Hold-out evaluation: errors before and after calibration, and the over-fitting guard."""

from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np

#: Held-out error increase [percentage points] tolerated before the guard refuses the tuning.
HOLDOUT_TOL_POINTS = 0.05


def before_after(evaluate: Callable[[Any, dict[str, float]], Any],
                 groups: Sequence[tuple[str, Sequence[Any]]], start: dict[str, float],
                 best: dict[str, float]) -> list[tuple[str, Any, Any, Any]]:
    """Evaluate every test of every group with the start and with the calibrated values.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(test, values)``: the errors of one test with the parameter ``values``.
    groups : sequence of (role, tests)
        The tuning tests and the held-out ones (``("tuned", tests), ("held out", tests)``).
    start, best : dict
        Parameter values before and after calibration (dotted names).

    Returns
    -------
    list of (role, test, before, after)
        In the order of ``groups`` and their tests.
    """
    out = []
    for role, tests in groups:
        for t in tests:
            out.append((role, t, evaluate(t, start), evaluate(t, best)))
    return out


def holdout_worse(before: dict[str, dict[str, float]], after: dict[str, dict[str, float]],
                  holdout: Sequence[str], tol: float = HOLDOUT_TOL_POINTS,
                  keys: tuple[str, ...] = ("fuel_pct", "soc_pct")) -> str:
    """Why the tuned values are worse on the held-out tests ('' when they are not).

    Worse means: the mean over the held-out tests of the absolute errors ``keys`` [%]
    (default |fuel error| and |final SOC error|) grew by more than ``tol`` points
    (quantities a test cannot give are left out).
    """
    def score(errs: dict[str, dict[str, float]]) -> float:
        vals = [abs(errs[t][k]) for t in holdout for k in keys
                if t in errs and errs[t].get(k) is not None and np.isfinite(errs[t][k])]
        return float(np.mean(vals)) if vals else float("nan")

    if not holdout:
        return ""
    b, a = score(before), score(after)
    if not (np.isfinite(a) and np.isfinite(b)) or a <= b + tol:
        return ""
    parts = [f"{t}: fuel {before[t]['fuel_pct']:.2f} -> {after[t]['fuel_pct']:.2f} %"
             for t in holdout if t in before and t in after]
    return "; ".join(parts)
