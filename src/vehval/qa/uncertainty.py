"""Cumulative uncertainties of the QA comparisons (Tables 2 and 3): En beside the differences.

Each row of Table 2 (sensor against sensor) and Table 3 (measured against calculated)
compares the whole-test means of its two sides over the samples it uses; their difference is
the row's signed mean difference ``mean_diff``. Its normalised error
(:func:`vehval.uncertainty.normalised_error`) is::

    En = mean_diff / sqrt(U_a^2 + U_b^2)        (k = 2)

with the sign of ``mean_diff`` (other - reference in Table 2, measured - calculated in
Table 3). ``|En| <= 1``: the two sides agree within their combined accuracy.

**Accuracy of a sensor** (:func:`vehval.uncertainty.sensors.channel_accuracy`, the one
resolver): the template's ``accuracy:`` entry of the signal when declared, else the default of
its class (``data/uncertainty/sensor_accuracy.yaml``, with its source), flagged assumed. It is
a limit of error held over the test, ``x (1 + g) + o`` with ``|g| <= G`` and ``|o| <= O``,
both rectangular (standard uncertainty = limit / sqrt(3)). The expanded uncertainty of the
mean of a signal over the compared samples is::

    U = 2 sqrt((G |mean|)^2 + O^2) / sqrt(3)

Sample noise averages out over the hundreds of samples of a comparison and is left out.

**Calculated signals** carry the propagated uncertainty of their measured inputs, followed
through intermediate ``_calc`` signals: first order (GUM law of propagation, uncorrelated
inputs), by central differences of the mean of the calculated signal over the compared
samples, one pair per input and error (gain, offset), step = its standard uncertainty;
``U_calc = 2 sqrt(sum (c_i u_i)^2)``. An input used in several places of the calculation is
perturbed everywhere at once (its correlation with itself is kept). Parameters of the
calculation (masses, road-load coefficients, ratios) are taken as exact: the calculated
side's U is that of its measurements only, and a model simplification (a steady-state
relation, set against target road load) shows as an En beyond 1 that is no sensor fault.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from vehval.equations.calc import CalcResult
from vehval.equations.expr import parse_expression
from vehval.errors import VehvalError
from vehval.test import Test
from vehval.uncertainty import normalised_error
from vehval.uncertainty.precision import COVERAGE_K
from vehval.uncertainty.sensors import ChannelAccuracy, channel_accuracy

_SQRT3 = math.sqrt(3.0)


class Accuracies:
    """Accuracy of each signal of a test: the template's declaration or the class default.

    Parameters
    ----------
    declared : mapping, optional
        Standard signal name -> ``AccuracySpec`` (template ``accuracy:``).
    """

    def __init__(self, declared: Mapping[str, Any] | None = None) -> None:
        self.declared = dict(declared or {})
        self._cache: dict[str, ChannelAccuracy] = {}

    def __call__(self, signal: str) -> ChannelAccuracy:
        if signal not in self._cache:
            self._cache[signal] = channel_accuracy(signal, self.declared.get(signal))
        return self._cache[signal]


def mean_uncertainty(acc: ChannelAccuracy, mean_value: float) -> float:
    """Expanded uncertainty (k = 2) of a signal's mean ``mean_value`` [its SI unit]."""
    return COVERAGE_K * math.hypot(acc.gain_limit * abs(mean_value), acc.offset_limit) / _SQRT3


def accuracy_entry(acc: ChannelAccuracy) -> dict[str, Any]:
    """The row's record of one side's accuracy (``reading_pct``, ``offset_si``, ``assumed``,
    ``basis``)."""
    return acc.to_dict()


def en_of(a_mean: float, b_mean: float, u_a: float, u_b: float, label: str) -> float:
    """En of the difference ``a_mean - b_mean`` (NaN when it cannot be given: a zero or
    non-finite reference mean, or both uncertainties zero)."""
    if not (math.isfinite(a_mean) and math.isfinite(b_mean)) or b_mean == 0.0:
        return float("nan")
    try:
        return normalised_error(a_mean, b_mean, u_a, u_b, label).en
    except VehvalError:
        return float("nan")


def pair_uncertainty(row: Any, acc: Accuracies) -> None:
    """Fill the uncertainty keys of a Table-2 row (``u_ref``, ``u_other``, ``en``,
    ``accuracy``) from its ``mean_ref`` and ``mean_diff``."""
    a, b = acc(row.ref), acc(row.other)
    mean_other = row.mean_ref + row.mean_diff
    row.u_ref = mean_uncertainty(a, row.mean_ref)
    row.u_other = mean_uncertainty(b, mean_other)
    row.en = en_of(mean_other, row.mean_ref, row.u_other, row.u_ref,
                   f"{row.other} vs {row.ref}")
    row.accuracy = {row.ref: accuracy_entry(a), row.other: accuracy_entry(b)}


class CalcChain:
    """Re-evaluates a calculated signal with its measured inputs perturbed."""

    def __init__(self, test: Test, calc: CalcResult) -> None:
        self.test, self.calc = test, calc
        self._measured: dict[str, np.ndarray] = {}

    def measured(self, name: str) -> np.ndarray:
        if name not in self._measured:
            self._measured[name] = self.test[name].at(self.calc.grid)
        return self._measured[name]

    def value(self, name: str, pert: Mapping[str, tuple[float, float]], depth: int = 0
              ) -> np.ndarray:
        """``name`` on the calc grid with ``pert`` (signal -> (gain, offset)) applied."""
        if not name.endswith("_calc"):
            g, o = pert.get(name, (0.0, 0.0))
            x = self.measured(name)
            return x * (1.0 + g) + o if (g or o) else x
        info = self.calc.computed[name]
        if depth > 20:
            raise VehvalError(f"{name}: calculation chain deeper than 20")
        ex = parse_expression(info["expr"], name)
        var: dict[str, object] = dict(info.get("parameters", {}))
        for v, sig in info.get("inputs", {}).items():
            var[v] = self.value(sig, pert, depth + 1)
        return ex.evaluate(var, self.calc.grid)


def calc_uncertainty(test: Test, calc: CalcResult, row: Any, mask: np.ndarray | None,
                     acc: Accuracies, inputs: set[str], chain: CalcChain | None = None) -> None:
    """Fill the uncertainty keys of a Table-3 row (``mean_diff``, ``u_measured``,
    ``u_calculated``, ``en``, ``accuracy``) over the samples it compared (``mask``);
    ``inputs``: the measured signals the calculated one rests on
    (:func:`vehval.qa.level3.measured_inputs`)."""
    chain = chain or CalcChain(test, calc)
    cname = row.calculated
    c = np.asarray(test[cname].values, float)
    m = chain.measured(row.measured)
    ok = np.isfinite(m) & np.isfinite(c)
    if mask is not None:
        ok &= mask
    if ok.sum() < 5:
        return
    m_mean, c_mean = float(np.mean(m[ok])), float(np.mean(c[ok]))
    row.mean_diff = m_mean - c_mean
    a = acc(row.measured)
    row.u_measured = mean_uncertainty(a, m_mean)
    var = 0.0
    record = {row.measured: accuracy_entry(a)}
    for name in sorted(inputs):
        if name not in test:
            continue
        ai = acc(name)
        record[name] = accuracy_entry(ai)
        for step in ((ai.gain_limit / _SQRT3, 0.0), (0.0, ai.offset_limit / _SQRT3)):
            if not any(step):
                continue
            neg = (-step[0], -step[1])
            hi = chain.value(cname, {name: step})[ok]
            lo = chain.value(cname, {name: neg})[ok]
            ci = 0.5 * float(np.nanmean(hi) - np.nanmean(lo))
            if math.isfinite(ci):
                var += ci * ci
    row.u_calculated = COVERAGE_K * math.sqrt(var)
    row.en = en_of(m_mean, c_mean, row.u_measured, row.u_calculated,
                   f"{row.measured} vs {cname}")
    row.accuracy = record


def comparison_lines(doc: Mapping[str, Any]) -> list[str]:
    """One screen line per Table-2/3 row of a ``findings.json`` document: the signed mean
    difference, the mean relative difference, each side's U (k = 2) and En."""
    from vehval.qa.findings import delta_units

    out: list[str] = []
    for table, a_key, b_key, ua, ub, rel, what in (
            ("table2", "other", "ref", "u_other", "u_ref", "mean_rel_diff", "mean |rel. diff|"),
            ("table3", "measured", "calculated", "u_measured", "u_calculated", "rel_diff",
             "mean |diff| / range")):
        for r in doc.get(table) or []:
            if r.get("mean_diff") is None or r.get(a_key) is None:
                continue
            fmt = delta_units(r[a_key], r.get("unit") or "")
            en = r.get("en")
            rel_txt = "" if r.get(rel) is None else f" ({what} {100 * r[rel]:.2g} %)"
            u = ("U n/a" if r.get(ua) is None or r.get(ub) is None
                 else f"U {fmt(r[ua])} / {fmt(r[ub])}")
            out.append(f"  {'Table 2' if table == 'table2' else 'Table 3'}  {r[a_key]} - "
                       f"{r[b_key]}: {fmt(r['mean_diff'], signed=True)}{rel_txt}, {u}, "
                       f"En {'n/a' if en is None else f'{en:+.2f}'}")
    return out
