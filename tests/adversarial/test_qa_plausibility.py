"""QA never validates impossible data (a channel stuck out of range, a one-row source)."""

from __future__ import annotations

import numpy as np

from vehval.qa.findings import Kind, Severity
from vehval.qa.pipeline import run_qa
from vehval.test import Signal, Test
from vehval.test import TestMeta as Meta


def _drive(duration: float = 300.0, dt: float = 0.1):
    t = np.arange(0.0, duration, dt)
    v = 10.0 + 8.0 * np.sin(t / 20.0) + 0.01 * np.random.default_rng(0).normal(size=t.size)
    return t, v


def _test(*signals: Signal) -> Test:
    test = Test(meta=Meta(test_id="adv"))
    for s in signals:
        test.add(s)
    return test


def test_stuck_out_of_range_voltage_is_an_error_and_never_selected():
    """99999 V constant battery voltage beside a plausible OBD one: an error, dropped."""
    t, v = _drive()
    t1 = np.arange(0.0, 300.0, 1.0)
    test = _test(Signal.standard("veh_spd_test", t, v, source="dyno"),
                 Signal.standard("ess_volt_test", t, np.full(t.size, 99999.0), source="dyno"),
                 Signal.standard("ess_volt_obd_test", t1, 201.6 + np.sin(t1), source="obd"),
                 Signal.standard("amb_temp_test", t, np.full(t.size, -9999.0), source="dyno"))
    res = run_qa(test, align=False)
    for name in ("ess_volt_test", "amb_temp_test"):
        errs = [f for f in res.findings if f.signal == name and f.kind == Kind.RANGE
                and f.severity == Severity.ERROR]
        assert errs, name
        assert name in res.selection.dropped and name not in res.selection.kept
    assert "ess_volt_obd_test" in res.selection.kept


def test_single_row_source_is_flagged_and_never_preferred():
    """A one-row facility file beside a 1,330 s OBD log: flagged, the OBD source kept."""
    t1 = np.arange(0.0, 1330.0, 1.0)
    v1 = 10.0 + 5.0 * np.sin(t1 / 30.0)
    test = _test(Signal.standard("veh_spd_test", np.array([0.0]), np.array([12.0]), source="dyno"),
                 Signal.standard("eng_spd_out_test", np.array([0.0]), np.array([150.0]),
                                 source="dyno"),
                 Signal.standard("veh_spd_obd_test", t1, v1, source="obd"),
                 Signal.standard("eng_spd_out_obd_test", t1, 150.0 + 10 * np.sin(t1 / 7),
                                 source="obd"))
    res = run_qa(test, align=False)
    for name in ("veh_spd_test", "eng_spd_out_test"):
        assert any(f.signal == name and f.kind == Kind.SPARSE and f.severity != Severity.INFO
                   for f in res.findings)
        assert name not in res.selection.kept
    assert {"veh_spd_obd_test", "eng_spd_out_obd_test"} <= set(res.selection.kept)


def test_few_samples_source_loses_to_the_complete_one():
    """Five facility samples over a 20-minute test: the OBD log is preferred."""
    t1 = np.arange(0.0, 1200.0, 1.0)
    test = _test(Signal.standard("veh_spd_test", np.linspace(0, 1200, 12), np.full(12, 9.0) +
                                 np.arange(12), source="dyno"),
                 Signal.standard("veh_spd_obd_test", t1, 10 + 5 * np.sin(t1 / 30), source="obd"))
    res = run_qa(test, align=False)
    assert res.selection.kept.keys() & {"veh_spd_obd_test"}
    assert "veh_spd_test" in res.selection.dropped
