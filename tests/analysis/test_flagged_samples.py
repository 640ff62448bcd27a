"""The analysis does not use SOC samples QA flagged (reported: SOC 0 flagged, yet the
analysis reported soc_min 0.04 from them)."""

from __future__ import annotations

import numpy as np

from vehval.analysis.inputs import mask_flagged_samples
from vehval.qa.findings import Finding, Kind, Severity
from vehval.test import Signal, Test


def test_flagged_soc_samples_are_not_used():
    t = np.arange(0.0, 100.0, 1.0)
    soc = np.full(t.size, 0.6)
    soc[40:43] = 0.0                                   # logger dropouts, flagged by QA
    test = Test([Signal.standard("ess_soc_obd_test", t, soc, source="obd")])
    flagged = Finding("ess_soc_obd_test", Kind.RANGE, 40.0, 42.0, Severity.WARNING, "SOC 0")
    whole = Finding("ess_soc_obd_test", Kind.GAIN, 0.0, 99.0, Severity.WARNING, "gain")
    found = mask_flagged_samples(test, [flagged, whole])
    v = test["ess_soc_obd_test"].values
    assert np.nanmin(v) == 0.6 and np.isnan(v[40:43]).all()
    assert np.isfinite(v).sum() == t.size - 3           # 40..42; the whole-test gain masks nothing
    assert [(f.kind, f.signal, f.count) for f in found] == [("excluded", "ess_soc_obd_test", 3)]
    assert "QA flagged are not used (SOC 0)" in found[0].message
