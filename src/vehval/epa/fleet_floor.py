"""The data's own floor for a model of the list's columns: what a perfect one would reach.

Two judged rows with the same procedure, the same make and the same columns of
:func:`vehval.epa.fleet_baseline.features` (test weight, road load, displacement, power,
cylinders, N/V, axle ratio, gears, transmission class, fuel and aspiration) are one car to
any model that reads those columns: it gives both one figure. Their measured figures still
differ (a repeated test, another test vehicle of the same configuration, another lab, a
calibration the list does not name), and no such model can do better than the spread
within these groups.

Per procedure, each row of a group of ``n >= 2`` gives its log deviation from the group's
mean, scaled by ``sqrt(n / (n - 1))`` (the deviation of one test from the true value, not
from a mean that holds it). Their distribution is the error of a perfect model of the
columns: its median |deviation| and its share within 5 % are the floor of the fleet
targets; the pooled standard deviation (``sigma``, ``dof`` degrees of freedom) is stated
too. The distribution has heavy tails (a few groups differ by over 10 %), so the median
and the share are read from the deviations themselves, not from ``sigma``.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any, Sequence

import numpy as np

from vehval.epa.fleet_baseline import features, make_key

#: least groups of a procedure to state its floor
MIN_GROUPS = 5
#: columns rounded to this many significant digits before grouping (list figures repeated
#: across rows convert to SI identically; the rounding only absorbs float noise)
_DIGITS = 6


def _key(r: dict[str, Any]) -> tuple | None:
    x = features(r)
    if x is None:
        return None
    return (r["procedure"], make_key(r),
            tuple(float(f"{v:.{_DIGITS}g}") for v in x))


def data_floor(rows: Sequence[dict[str, Any]],
               mix: dict[str, int] | None = None) -> dict[str, Any]:
    """The floor of a model of the row's columns on judged ``rows`` (records with
    ``procedure`` and ``measured_mpg``).

    Returns ``per_procedure``: procedure -> ``n_groups``, ``n_rows`` (rows in groups of two
    or more), ``dof``, ``sigma`` (pooled standard deviation of one test, log [-]),
    ``median_abs_error`` and ``share_within_5pct`` of a perfect model [-] (procedures with
    fewer than :data:`MIN_GROUPS` groups are left out); and ``share_within_5pct`` over
    procedures weighted by ``mix`` (procedure -> judged rows; default: the groups' rows)."""
    groups: dict[tuple, list[float]] = defaultdict(list)
    for r in rows:
        key = _key(r)
        if key is not None and r.get("measured_mpg"):
            groups[key].append(math.log(r["measured_mpg"]))
    dev: dict[str, list[float]] = defaultdict(list)
    stats: dict[str, list[float]] = defaultdict(lambda: [0, 0, 0.0])
    for (proc, *_), x in groups.items():
        if len(x) < 2:
            continue
        a = np.asarray(x)
        c = a - a.mean()
        n = len(a)
        dev[proc] += list(c * math.sqrt(n / (n - 1)))
        s = stats[proc]
        s[0] += 1
        s[1] += n - 1
        s[2] += float(c @ c)
    per = {}
    for proc in sorted(dev):
        n_groups, dof, ss = stats[proc]
        if n_groups < MIN_GROUPS:
            continue
        d = np.abs(np.expm1(-np.asarray(dev[proc])))  # a perfect prediction's |error|
        per[proc] = {"n_groups": int(n_groups), "n_rows": len(d), "dof": int(dof),
                     "sigma": math.sqrt(ss / dof), "median_abs_error": float(np.median(d)),
                     "share_within_5pct": float(np.mean(d <= 0.05))}
    weights = {p: (mix or {}).get(p, st["n_rows"] if mix is None else 0) for p, st in per.items()}
    total = sum(weights.values())
    share = (sum(weights[p] * per[p]["share_within_5pct"] for p in per) / total
             if total else None)
    return {"per_procedure": per, "share_within_5pct": share}
