"""Model-vs-test verdicts from uncertainties: the normalised error and the set verdict.

**Normalised error** of one comparison (ISO 13528 / ISO/IEC 17043 style)::

    En = (model - measured) / sqrt(U_model^2 + U_meas^2)

with expanded uncertainties (k = 2, about 95 %) in the unit of the figure. ``U_meas``
combines the measured result's own propagated uncertainty (the channels' accuracies,
:mod:`vehval.results.uncertainty`) with the spread of a repeated measurement:

* model and measurement from the same lab and car: ``k s_r |measured|``;
* from different labs or cars (a model tuned on the manufacturer's tests judged against the
  EPA lab's, or a model of one car against another car of the type): ``k s_R |measured|``.
  s_R already holds s_r (s_R^2 = s_L^2 + s_r^2), so the two are not added.

``|En| <= 1`` is consistent. A comparison is **uninformative** when the combined
``sqrt(U_model^2 + U_meas^2)`` exceeds :data:`UNINFORMATIVE_FRACTION` (10 %) of
``|measured|``: then a model 10 % off, twice the usual 5 % tolerance and beyond every
EPA-against-manufacturer spread measured on the Test Car Lists, would still pass; En is
computed but says little.

**Set verdict** over n comparisons with relative errors ``e_i = model_i / measured_i - 1``:

* bias: the mean ``ebar`` with its 95 % t-interval ``ebar +- t_{0.975, n-1} s_e / sqrt(n)``.
  It is called a bias when the interval excludes zero **and** ``|ebar|`` exceeds what the
  test scatter explains for a mean of n results, ``k u_ref`` with
  ``u_ref = sqrt(s_r^2 / n + s_L^2)``: s_r averages down over the tests, the between-lab
  part ``s_L^2 = s_R^2 - s_r^2`` does not (it is common to every test of one lab) and counts
  only when the model and the tests come from different labs or cars.
* coverage: the share of comparisons with ``|En| <= 1`` and its Clopper-Pearson (exact
  binomial) 95 % interval; the uncertainties are **understated** when the interval lies
  wholly below 95 %.
* verdict: ``biased by x +- y %`` (x = 100 ebar, y = the t half-width) when biased; else
  ``uncertainty understated``; else ``consistent with the data``.
* beside it, the same bias test against s_r alone (``bias_limit_s_r = k s_r / sqrt(n)``,
  ``beyond_s_r``): whether the mean error is beyond what one lab's repeatability explains,
  which tells a between-lab offset from a spread of repeats when the set's verdict rests on
  s_R.

**Published figures** (:func:`judge_published`): a simulated figure against a figure from a
report or a label, another car in another lab, so U_meas is the packaged vehicle-level s_R
of the cycle's procedure and the family (:mod:`vehval.uncertainty.defaults`) combined with
the uncertainty the source states (rounding, say).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from vehval.errors import VehvalError
from vehval.uncertainty.defaults import cycle_precision
from vehval.uncertainty.precision import COVERAGE_K, InsufficientDataError, stats

#: A comparison is uninformative when its combined U exceeds this share of |measured| [-].
UNINFORMATIVE_FRACTION = 0.10
#: Nominal coverage of |En| <= 1 the set is judged against [-].
TARGET_COVERAGE = 0.95
#: Fewest comparisons a set verdict is given for.
MIN_SET = 3

CONSISTENT = "consistent with the data"
UNDERSTATED = "uncertainty understated"


def measurement_uncertainty(measured: float, *, u_result: float = 0.0, s_r: float = 0.0,
                            s_R: float | None = None, different_source: bool = False,
                            k: float = COVERAGE_K) -> float:
    """Expanded uncertainty U_meas of a measured figure, in its unit.

    Parameters
    ----------
    measured : float
        The measured figure (any unit).
    u_result : float
        The result's own expanded uncertainty (k = 2) from its channels, same unit.
    s_r, s_R : float
        Repeatability and reproducibility, relative standard deviations [-].
    different_source : bool
        Model and measurement from different labs or cars: s_R is used instead of s_r.
    k : float
        Coverage factor applied to s_r / s_R.

    Raises
    ------
    VehvalError
        A negative uncertainty, or ``different_source`` without s_R.
    """
    if different_source and s_R is None:
        raise VehvalError("U_meas: model and measurement come from different labs or cars, "
                          "which needs the reproducibility s_R (none given)")
    s = s_R if different_source and s_R is not None else s_r
    if min(u_result, s) < 0.0:
        raise VehvalError(f"U_meas: uncertainties cannot be negative (U_result {u_result:g}, "
                          f"s {s:g})")
    return math.hypot(u_result, k * s * abs(measured))


@dataclass(frozen=True)
class Comparison:
    """One model-vs-measured comparison with its normalised error.

    Attributes
    ----------
    model, measured : float
        The two figures (same unit).
    u_model, u_meas : float
        Expanded uncertainties (k = 2), same unit.
    en : float
        Normalised error [-] (NaN when both uncertainties are zero).
    error : float
        Relative error model / measured - 1 [-].
    uninformative : bool
        Combined U over :data:`UNINFORMATIVE_FRACTION` of |measured|.
    label : str
        What was compared (test, figure).
    """

    model: float
    measured: float
    u_model: float
    u_meas: float
    en: float
    error: float
    uninformative: bool
    label: str = ""

    @property
    def consistent(self) -> bool:
        """|En| <= 1."""
        return math.isfinite(self.en) and abs(self.en) <= 1.0

    def to_dict(self) -> dict[str, Any]:
        out = {"label": self.label, "model": self.model, "measured": self.measured,
               "u_model": self.u_model, "u_meas": self.u_meas, "en": self.en,
               "error_pct": 100 * self.error, "consistent": self.consistent,
               "uninformative": self.uninformative}
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in out.items()}


def normalised_error(model: float, measured: float, u_model: float, u_meas: float,
                     label: str = "") -> Comparison:
    """En = (model - measured) / sqrt(U_model^2 + U_meas^2) and the uninformative flag.

    Parameters
    ----------
    model, measured : float
        Predicted and measured figure (same unit; measured non-zero).
    u_model, u_meas : float
        Expanded uncertainties (k = 2), same unit, >= 0.
    """
    if not (math.isfinite(model) and math.isfinite(measured)) or measured == 0.0:
        raise VehvalError(f"En{' of ' + label if label else ''}: model {model:g} and measured "
                          f"{measured:g} must be finite and the measured figure non-zero")
    if not (u_model >= 0.0 and u_meas >= 0.0):
        raise VehvalError(f"En{' of ' + label if label else ''}: uncertainties must be >= 0 "
                          f"(U_model {u_model:g}, U_meas {u_meas:g})")
    u = math.hypot(u_model, u_meas)
    en = (model - measured) / u if u > 0.0 else math.nan
    return Comparison(model, measured, u_model, u_meas, en, model / measured - 1.0,
                      u > UNINFORMATIVE_FRACTION * abs(measured), label)


@dataclass(frozen=True)
class SetVerdict:
    """Verdict over several comparisons.

    Attributes
    ----------
    n : int
        Comparisons judged.
    mean_error : float
        Mean relative error [-].
    mean_error_ci : tuple of float
        Its 95 % t-interval [-].
    bias_limit : float
        What the test scatter explains for the mean, k u_ref [-].
    biased : bool
    n_consistent : int
        Comparisons with |En| <= 1.
    coverage : float
        n_consistent / n [-].
    coverage_ci : tuple of float
        Clopper-Pearson 95 % interval of the coverage [-].
    understated : bool
        The coverage interval lies wholly below :data:`TARGET_COVERAGE`.
    n_uninformative : int
    verdict : str
        ``consistent with the data``, ``biased by x +- y %`` or ``uncertainty understated``.
    notes : list of str
    """

    n: int
    mean_error: float
    mean_error_ci: tuple[float, float]
    bias_limit: float
    biased: bool
    n_consistent: int
    coverage: float
    coverage_ci: tuple[float, float]
    understated: bool
    n_uninformative: int
    verdict: str
    notes: list[str] = field(default_factory=list)
    #: what s_r alone explains for the mean, k s_r / sqrt(n) [-]
    bias_limit_s_r: float = 0.0
    #: the mean error's interval excludes 0 and |mean| exceeds bias_limit_s_r
    beyond_s_r: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {"n": self.n, "mean_error_pct": 100 * self.mean_error,
                "mean_error_ci_pct": [100 * v for v in self.mean_error_ci],
                "bias_limit_pct": 100 * self.bias_limit, "biased": self.biased,
                "n_consistent": self.n_consistent, "coverage": self.coverage,
                "coverage_ci": list(self.coverage_ci), "understated": self.understated,
                "n_uninformative": self.n_uninformative, "verdict": self.verdict,
                "notes": list(self.notes), "bias_limit_s_r_pct": 100 * self.bias_limit_s_r,
                "beyond_s_r": self.beyond_s_r}


def clopper_pearson(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact binomial (Clopper-Pearson) interval of a share k / n [-]."""
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
    return float(ci.low), float(ci.high)


def set_verdict(comparisons: Sequence[Comparison], *, s_r: float, s_R: float | None = None,
                different_source: bool = False, k: float = COVERAGE_K) -> SetVerdict:
    """Bias, coverage and verdict of several comparisons (see the module docstring).

    Parameters
    ----------
    comparisons : sequence of Comparison
        At least :data:`MIN_SET`.
    s_r : float
        Repeatability of one measured result [-].
    s_R : float, optional
        Reproducibility [-]; with ``different_source`` its between-lab part is added to
        what the scatter explains for the mean.
    different_source : bool
        Model and tests from different labs or cars.
    k : float
        Coverage factor of the bias limit.

    Raises
    ------
    InsufficientDataError
        Fewer than :data:`MIN_SET` comparisons (the count is named).
    """
    n = len(comparisons)
    if n < MIN_SET:
        raise InsufficientDataError(f"set verdict: {n} comparison(s); at least {MIN_SET} are "
                                    "needed for a bias with an interval and a coverage")
    if different_source and s_R is None:
        raise VehvalError("set verdict: model and tests from different labs or cars need the "
                          "reproducibility s_R (none given)")
    e = [c.error for c in comparisons]
    mean = sum(e) / n
    sd = math.sqrt(sum((x - mean) ** 2 for x in e) / (n - 1))
    half = float(stats.t.ppf(0.975, n - 1)) * sd / math.sqrt(n)
    s_l2 = max((s_R or 0.0) ** 2 - s_r ** 2, 0.0) if different_source else 0.0
    limit = k * math.sqrt(s_r ** 2 / n + s_l2)
    excludes_zero = mean - half > 0.0 or mean + half < 0.0
    biased = excludes_zero and abs(mean) > limit
    limit_r = k * s_r / math.sqrt(n)
    n_ok = sum(c.consistent for c in comparisons)
    cov_ci = clopper_pearson(n_ok, n)
    understated = cov_ci[1] < TARGET_COVERAGE
    n_unin = sum(c.uninformative for c in comparisons)
    notes = []
    if n_unin:
        notes.append(f"{n_unin} of {n} comparisons are uninformative (combined U over "
                     f"{100 * UNINFORMATIVE_FRACTION:g} % of the measured figure)")
    if biased:
        verdict = f"biased by {100 * mean:+.1f} +- {100 * half:.1f} %"
        if understated:
            notes.append("the coverage is below 95 % too; the bias explains at least part")
    elif understated:
        verdict = UNDERSTATED
    else:
        verdict = CONSISTENT
    return SetVerdict(n, mean, (mean - half, mean + half), limit, biased, n_ok, n_ok / n,
                      cov_ci, understated, n_unin, verdict, notes, limit_r,
                      excludes_zero and abs(mean) > limit_r)


def verdict_text(sv: dict[str, Any], what: str = "") -> str:
    """One line of a set verdict (``SetVerdict.to_dict()``), as every command and page says
    it: ``set verdict (WHAT, n = N): VERDICT; mean error +x.xx % [lo, hi] (the scatter
    explains y.yy %); |En| <= 1 for k/N (coverage [a, b] %, target 95 %)``."""
    lo, hi = sv["mean_error_ci_pct"]
    clo, chi = sv["coverage_ci"]
    head = f"{what}, n = {sv['n']}" if what else f"n = {sv['n']}"
    return (f"set verdict ({head}): {sv['verdict']}; mean error {sv['mean_error_pct']:+.2f} % "
            f"[{lo:+.2f}, {hi:+.2f}] (the scatter explains {sv['bias_limit_pct']:.2f} %); "
            f"|En| <= 1 for {sv['n_consistent']}/{sv['n']} (coverage [{100 * clo:.0f}, "
            f"{100 * chi:.0f}] %, target {100 * TARGET_COVERAGE:.0f} %)")


def judge_published(model: float, measured: float, *, u_model: float, cycle: str,
                    family: str, u_stated: float = 0.0, label: str = ""
                    ) -> tuple[Comparison, dict[str, Any]]:
    """En of a simulated figure against a published one (another car, another lab).

    Parameters
    ----------
    model, measured : float
        Simulated and published figure (same unit, e.g. mpg).
    u_model : float
        The model's expanded uncertainty (k = 2), same unit.
    cycle : str
        The published figure's cycle; its packaged procedure
        (:func:`vehval.uncertainty.defaults.cycle_precision`, FTP-75 for a cycle without one).
    family : str
        Powertrain family of the packaged precision (``hybrid``, ``conventional``...).
    u_stated : float
        Expanded uncertainty the source states for the figure (rounding...), same unit.

    Returns
    -------
    (Comparison, dict)
        The comparison and the basis of U_meas: ``s_r``, ``s_R`` (the s used), ``which``
        (``s_R_vehicle``, ``s_R`` or ``s_r`` when the defaults hold no s_R), ``u_stated``,
        ``note`` (a borrowed procedure) and ``provenance``.
    """
    d, note = cycle_precision(cycle, family)
    which = next((q for q in ("s_R_vehicle", "s_R", "s_r") if getattr(d, q) is not None), None)
    if which is None:
        raise VehvalError(f"no packaged precision for {family} {d.procedure}: U_meas of "
                          f"{label or cycle} cannot be formed")
    s = float(getattr(d, which))
    s_r = float(d.s_r) if d.s_r is not None else s
    u_meas = measurement_uncertainty(measured, u_result=u_stated, s_r=s_r, s_R=s,
                                     different_source=True)
    return (normalised_error(model, measured, u_model, u_meas, label=label),
            {"s_r": s_r, "s_R": s, "which": which, "procedure": d.procedure,
             "u_stated": u_stated, "note": note, "provenance": d.provenance})
