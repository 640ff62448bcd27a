"""Integrals over time and battery power from voltage and current: the one owner.

Every stage that turns a rate into an amount (speed into distance, fuel rate into fuel mass,
power into energy) integrates here, so that a figure of the results, of QA's cross-checks, of
validation, of a batch and of a report page is the same number for the same signal.

Rules
-----
* **Trapezoid over the finite samples** (:func:`integral`, :func:`cumulative`,
  :func:`window_integral`): a sample whose time or value is not finite is dropped, and the gap
  it leaves is bridged linearly by its finite neighbours (a dropout is not a zero). Fewer than
  two finite samples give NaN: the amount is unknown, not zero.
* **Zero-order hold** (:func:`held_sum`, :func:`window_integral` with ``step_s``): a
  simulator's output on its uniform grid holds each step's value over ``[t, t + step)``,
  and the simulator accounts its own totals that way, so a window of its output sums the
  samples with ``a <= t < b`` times the step. A trapezoid there would disagree with the
  simulator's totals by half a step at each end.
* **Battery** (:func:`battery_power`, :func:`battery_energy`): power is voltage x current
  with the nomenclature's sign, current positive discharging, so power is positive
  discharging and the energy is net, positive discharged [J].

Standard library and numpy only (a foundation module: every layer may import it).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import ArrayLike

#: A time window ``(start, end)`` [s]; ``end`` None runs to the end of the record.
Window = tuple[float, float | None]


def _finite(time_s: ArrayLike, values: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    t, v = np.asarray(time_s, float), np.asarray(values, float)
    ok = np.isfinite(t) & np.isfinite(v)
    return t[ok], v[ok]


def _steps(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Trapezoid area of each interval between consecutive samples [unit·s]."""
    return 0.5 * (v[1:] + v[:-1]) * np.diff(t)


def integral(time_s: ArrayLike, values: ArrayLike) -> float:
    """Whole-record trapezoidal integral of ``values`` over ``time_s`` [unit·s].

    Non-finite samples are dropped (their gap bridged by the finite neighbours); NaN when
    fewer than two finite samples remain.
    """
    t, v = _finite(time_s, values)
    if t.size < 2:
        return float("nan")
    return float(np.sum(_steps(t, v)))


def cumulative(time_s: ArrayLike, values: ArrayLike) -> np.ndarray:
    """Cumulative trapezoidal integral from the first sample [unit·s], same shape as ``values``.

    Built on the finite samples (gaps bridged); a non-finite sample takes the cumulative
    value at its time (0 before the first finite sample, the total after the last). Zeros
    when fewer than two finite samples.
    """
    t_all = np.asarray(time_s, float)
    t, v = _finite(t_all, values)
    if t.size < 2:
        return np.zeros(t_all.shape)
    c = np.concatenate([[0.0], np.cumsum(_steps(t, v))])
    return np.interp(t_all, t, c)


def window_integral(time_s: ArrayLike, values: ArrayLike, windows: Iterable[Window], *,
                    step_s: float | None = None) -> float:
    """Integral of ``values`` over the union of time ``windows`` [unit·s].

    Without ``step_s``: the trapezoid of the finite samples (gaps bridged), read between the
    window ends on the cumulative integral (a window end between two samples is
    interpolated); NaN when fewer than two finite samples. With ``step_s`` [s]: the
    zero-order hold of a simulator's output, ``sum(values[a <= t < b]) * step_s``.
    """
    wins = [(float(a), np.inf if b is None else float(b)) for a, b in windows]
    if step_s is not None:
        t, v = np.asarray(time_s, float), np.asarray(values, float)
        total = 0.0
        for a, b in wins:
            total += held_sum(v, step_s, (t >= a) & (t < b))
        return total
    t, v = _finite(time_s, values)
    if t.size < 2:
        return float("nan")
    c = np.concatenate([[0.0], np.cumsum(_steps(t, v))])
    return float(sum(np.interp(b, t, c) - np.interp(a, t, c) for a, b in wins))


def held_sum(values: ArrayLike, step_s: float, where: ArrayLike | None = None) -> float:
    """Zero-order-hold integral of samples on a uniform grid of step ``step_s`` [s]:
    ``sum(values[where]) * step_s`` [unit·s] (all samples without ``where``, a boolean mask).
    """
    v = np.asarray(values, float)
    if where is not None:
        v = v[np.asarray(where, bool)]
    return float(np.sum(v)) * step_s


def battery_power(volt_v: ArrayLike, curr_a: ArrayLike) -> np.ndarray:
    """Battery power [W] from voltage [V] and current [A], positive discharging.

    The nomenclature's current is positive discharging, so ``P = U * I`` carries the sign of
    ``ess_pwr``. With the open-circuit voltage this is the chemical power.
    """
    return np.asarray(volt_v, float) * np.asarray(curr_a, float)


def battery_energy(time_s: ArrayLike, volt_v: ArrayLike, curr_a: ArrayLike) -> float:
    """Net battery energy [J] over the record, positive discharged (:func:`integral` of U x I)."""
    return integral(time_s, battery_power(volt_v, curr_a))
