"""Model validation and calibration against test data.

Public API
----------
:func:`validate_test`
    Simulate a vehicle on a test's own conditions and compare (:class:`Validation`).
:func:`compare`
    Test vs simulation: summary (Figure 17 style), component metrics, events, overlays.
:func:`ladder`
    Verdicts per cycle on the steady / low-transient / high-transient ladder.
:func:`calibrate`
    Tune named parameters on several tests, check on held-out tests.
:func:`variability`
    Test-to-test variability of repeated tests.
"""

from __future__ import annotations

from vehval.validate.compare import Comparison, compare, overlay_figures
from vehval.validate.ladder import LadderResult, Tolerances, ladder, rung_of
from vehval.validate.validation import Validation, validate_test
from vehval.validate.variability import Variability, error_vs_repeatability, variability

__all__ = ["Comparison", "compare", "overlay_figures", "LadderResult", "Tolerances", "ladder",
           "rung_of", "Validation", "validate_test", "Variability", "variability",
           "error_vs_repeatability", "calibrate", "CalibrationResult"]


def __getattr__(name):  # calibration pulls in scipy.optimize: import it on first use
    if name in ("calibrate", "CalibrationResult"):
        from vehval.validate import calibration as _c
        return getattr(_c, name)
    raise AttributeError(name)
