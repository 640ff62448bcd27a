"""QA level 2: Table-2 metrics against hand computation; faults between sources."""

import numpy as np
import pytest

from vehval.nomenclature import preference_rank
from vehval.qa.findings import Kind, Severity
from vehval.qa.level2 import compare_pair, run_level2
from vehval.test import Signal, Test

from .helpers import make_test


def test_table2_metrics_hand_computed():
    # same time base: ref = [1, 2, 3, 4, 5, 6], other = 2 ref + 1 (exact line)
    t = np.arange(6.0)
    a = Signal.standard("eng_spd_out_test", t, [1, 2, 3, 4, 5, 6.0])
    b = Signal.standard("eng_spd_out_obd_test", t, [3, 5, 7, 9, 11, 13.0])
    row = compare_pair(a, b)
    assert row.n == 6
    assert row.r2 == pytest.approx(1.0, abs=1e-12)
    assert row.slope == pytest.approx(2.0, abs=1e-12)
    assert row.offset == pytest.approx(1.0, abs=1e-12)
    # |b - a| = a + 1 = [2..7], mean 4.5; mean |a| = 3.5
    assert row.mean_abs_diff == pytest.approx(4.5, abs=1e-12)
    assert row.mean_rel_diff == pytest.approx(4.5 / 3.5, abs=1e-12)


def test_table2_r2_hand_computed_with_noise():
    t = np.arange(5.0)
    a = Signal.standard("veh_spd_test", t, [0, 1, 2, 3, 4.0])
    b = Signal.standard("veh_spd_obd_test", t, [0, 1, 3, 3, 4.0])
    row = compare_pair(a, b)
    # hand: da = [-2,-1,0,1,2], db = [-2.2,-1.2,0.8,0.8,1.8]; Sab = 4.4+1.2+0+0.8+3.6 = 10,
    # Saa = 10, Sbb = 4.84+1.44+0.64+0.64+3.24 = 10.8 -> r^2 = 100/108, slope 1, offset 0.2
    assert row.r2 == pytest.approx(100 / 108, abs=1e-12)
    assert row.slope == pytest.approx(1.0, abs=1e-12)
    assert row.offset == pytest.approx(0.2, abs=1e-12)
    assert row.mean_abs_diff == pytest.approx(0.2, abs=1e-12)


def test_preference_facility_first():
    names = ["eng_spd_out_obd_test", "eng_spd_out_test", "eng_spd_out_dyno_test", "eng_spd_out_x_test"]
    assert sorted(names, key=preference_rank)[0] == "eng_spd_out_test"
    assert sorted(names, key=preference_rank)[-1] == "eng_spd_out_x_test"


def _with(test, name, values):
    s = test[name]
    test.add(Signal.standard(name, s.time, values, source=s.source), replace_existing=True)


@pytest.mark.parametrize("fault,kind", [
    (lambda v: 1.12 * v, Kind.GAIN),
    (lambda v: -v, Kind.SIGN_FLIP),
    (lambda v: v * 60 / (2 * np.pi), Kind.UNIT),
    (lambda v: v + 40.0, Kind.OFFSET),
])
def test_faults_between_sources(fault, kind):
    test = make_test(seed=21)
    _with(test, "eng_spd_out_obd_test", fault(test["eng_spd_out_obd_test"].values))
    rows, found = run_level2(test)
    hit = [f for f in found if f.kind == kind]
    assert hit and all(f.signal == "eng_spd_out_obd_test" for f in hit), [(f.kind, f.signal) for f in found]
    assert not [f for f in found if f.signal == "veh_spd_obd_test"]


def test_three_sources_blame_the_odd_one():
    test = make_test(seed=22)
    s = test["eng_spd_out_test"]
    test.add(Signal.standard("eng_spd_out_daq_test", s.time, 1.15 * s.values, source="dyno"))
    _, found = run_level2(test)
    blamed = {f.signal for f in found if f.severity != Severity.INFO}
    assert blamed == {"eng_spd_out_daq_test"}


def test_clean_sources_agree():
    rows, found = run_level2(make_test(seed=23))
    assert found == []
    assert {r.base for r in rows} == {"eng_spd_out", "veh_spd"}
    assert all(r.r2 > 0.99 and abs(r.residual_lag_s) < 0.1 for r in rows)


def test_unit_factor_only_for_its_quantity():
    # the two accelerator-pedal sensors of a car differ by design (sensor B reads about
    # 1.6 x sensor A): a gain finding, not "mph vs km/h" on a position [1]
    t = np.arange(200.0)
    a = 0.3 * (1 + np.sin(t / 7.0))
    ref = Signal.standard("drv_pos_accel_test", t, a)
    other = Signal.standard("drv_pos_accel_b_test", t, 1.61 * a)
    test = Test([ref, other])
    _, found = run_level2(test)
    kinds = {f.kind for f in found}
    assert Kind.UNIT not in kinds and Kind.GAIN in kinds, [f.message for f in found]
    # the same ratio on a speed [m/s] is the mph vs km/h mix-up
    test = Test([Signal.standard("veh_spd_test", t, 10 * a),
                           Signal.standard("veh_spd_obd_test", t, 10 * 1.609344 * a)])
    _, found = run_level2(test)
    assert [f.kind for f in found if f.severity == Severity.ERROR] == [Kind.UNIT]
    assert "mph vs km/h" in found[0].message


def test_diagnostic_counters_are_not_one_quantity():
    # warm-ups, distance and time since codes cleared share the base diag_count but are
    # three counters: comparing them as sources of one quantity gives nonsense gains
    t = np.arange(100.0)
    test = Test([Signal.standard("diag_count_warmups_test", t, np.full(100, 24.0)),
                        Signal.standard("diag_count_dist_test", t, 220 + t / 60),
                        Signal.standard("diag_count_time_test", t, 48_000 + t / 60 * 216)])
    rows, found = run_level2(test)
    assert rows == [] and found == []


def test_two_tracks_apart_by_an_offset_are_an_offset_not_a_gain():
    # the Prius c's second pedal track reads the first + 15.7 % (fit slope 1.02): the ratio
    # of means (1.67 at a pedal mostly at rest) called it "gain differs by +67 %"
    t = np.arange(400.0)
    a = 0.16 + 0.1 * np.clip(np.sin(t / 9.0), 0.0, None)
    test = Test([Signal.standard("drv_pos_accel_test", t, a),
                 Signal.standard("drv_pos_accel_b_test", t, 1.02 * a + 0.157)])
    _, found = run_level2(test)
    assert [f.kind for f in found if f.severity != Severity.INFO] == [Kind.OFFSET], \
        [f.message for f in found]
    assert "offset from drv_pos_accel_test by +16.08 % on average" in found[0].message
