"""Uncertainty of comparisons: test precision from data and verdicts from it.

* :mod:`~vehval.uncertainty.precision`: repeatability s_r and reproducibility s_R (relative
  standard deviations with their counts and chi-square intervals);
* :mod:`~vehval.uncertainty.verdict`: the normalised error En of one comparison and the set
  verdict (bias, coverage) of several;
* :mod:`~vehval.uncertainty.defaults`: the packaged s_r / s_R measured on the EPA Test Car
  Lists, with their provenance.

This package depends on nothing above the base layer, so that every stage (QA, results,
validate, EPA, report) can use it.
"""

from vehval.uncertainty.precision import (
    COVERAGE_K,
    MIN_PAIRS,
    InsufficientDataError,
    LabPair,
    Precision,
    chi2_interval,
    repeatability,
    reproducibility,
)
from vehval.uncertainty.verdict import (
    UNINFORMATIVE_FRACTION,
    Comparison,
    SetVerdict,
    clopper_pearson,
    judge_published,
    measurement_uncertainty,
    normalised_error,
    set_verdict,
    verdict_text,
)

__all__ = ["COVERAGE_K", "MIN_PAIRS", "UNINFORMATIVE_FRACTION", "Comparison",
           "InsufficientDataError", "LabPair", "Precision", "SetVerdict", "chi2_interval",
           "clopper_pearson", "judge_published", "measurement_uncertainty", "normalised_error",
           "repeatability", "reproducibility", "set_verdict", "verdict_text"]
