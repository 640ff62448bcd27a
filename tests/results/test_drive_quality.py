"""SAE J2951 metrics on constructed traces with hand-computed values."""

import numpy as np
import pytest

from vehval.constants import MPH_M_PER_S
from vehval.results.drive_quality import drive_quality, iwr_reading


def _trace():
    # accelerate 0 -> 20 m/s in 20 s, hold 20 s, brake to 0 in 20 s; 10 Hz
    t = np.arange(0.0, 60.0 + 1e-9, 0.1)
    v = np.interp(t, [0, 20, 40, 60], [0, 20, 20, 0])
    return t, v


def test_scaled_trace_gives_the_hand_computed_ratings():
    t, vt = _trace()
    vd = 1.02 * vt                                   # driver 2 % fast everywhere
    dq = drive_quality(t, vd, vt, mass_kg=1000.0, road_load=(0.0, 0.0, 0.0))
    # distance and speed change scale by 1.02, inertial work (m a v dt) by 1.02^2
    assert dq.dr_pct == pytest.approx(2.0, abs=1e-9)
    assert dq.ascr_pct == pytest.approx(2.0, abs=1e-9)
    assert dq.iwr_pct == pytest.approx(4.04, abs=1e-9)
    assert dq.er_pct == pytest.approx(4.04, abs=1e-9)        # no road load: CE = inertial work
    assert dq.eer_pct == pytest.approx((1 - 1.02 / 1.0404) * 100, abs=1e-9)
    # RMSSE = 0.02 * rms(v_T): hand value over the samples
    assert dq.rmsse_mps == pytest.approx(0.02 * np.sqrt(np.mean(vt ** 2)), rel=1e-12)
    assert dq.within_tolerance is False                      # IWR 4.04 % > 4.0 %


def test_road_load_enters_the_energy_rating_by_hand():
    t, vt = _trace()
    dq = drive_quality(t, 1.02 * vt, vt, mass_kg=1000.0, road_load=(100.0, 0.0, 0.0))
    m = 1.015 * 1000.0
    # target: accelerating (a = 1) F = 100 + m over 200 m; plateau 100 N over 400 m;
    # braking F = 100 - m < 0 counts nothing
    ce_t = (100.0 + m) * 200.0 + 100.0 * 400.0
    ce_d = (100.0 + m * 1.02) * 204.0 + 100.0 * 408.0
    assert dq.er_pct == pytest.approx((ce_d / ce_t - 1) * 100, abs=1e-6)
    assert dq.eer_pct == pytest.approx((1 - 1.02 / (ce_d / ce_t)) * 100, abs=1e-6)


def test_window_violations_counted_per_event():
    t, vt = _trace()
    vd = vt.copy()
    vd[(t >= 30) & (t < 33)] += 3.0 * MPH_M_PER_S   # 3 mph over on the plateau for 3 s
    dq = drive_quality(t, vd, vt)
    assert dq.violations == 1
    assert dq.violation_s == pytest.approx(3.0, abs=0.11)
    assert dq.er_pct is None                          # no mass or road load: ER undefined
    assert dq.dr_pct > 0                              # the 3 s fast bit adds distance


def test_too_short_is_none():
    t = np.arange(5) * 0.1
    assert drive_quality(t, t, t) is None


def test_one_hz_driven_data_are_resampled_to_ten_hz():
    # J2951 step 1: the 1 Hz samples of a trace with knots on whole seconds, linearly
    # interpolated to 10 Hz, are the 10 Hz trace: the hand values of the 10 Hz case hold
    t, vt = _trace()
    t1 = t[::10]
    dq = drive_quality(t1, 1.02 * vt[::10], vt[::10], mass_kg=1000.0, road_load=(0.0, 0.0, 0.0))
    assert dq.samples == 601                                  # 60 s on the 10 Hz grid
    assert dq.iwr_pct == pytest.approx(4.04, abs=1e-9)
    assert dq.dr_pct == pytest.approx(2.0, abs=1e-9)


def test_cruise_corrections_raise_iwr_by_the_hand_computed_work():
    # the driver holds the 20 m/s cruise (20..40 s) with +-e corrections every 0.1 s,
    # starting below: 99 rises of 2e at 20 m/s and a last rise of e (mean 20 - e/2) back to
    # the trace at 40 s. Reference IWT = M x 20^2 / 2 (0 -> 20 m/s), M = 1.015 x 1000 kg.
    t, vt = _trace()
    e = 0.01
    vd = vt.copy()
    idx = np.flatnonzero((t > 20.05) & (t < 39.95))
    assert idx.size == 199
    vd[idx] += e * np.where(np.arange(idx.size) % 2 == 0, -1.0, 1.0)
    dq = drive_quality(t, vd, vt, mass_kg=1000.0)
    cruise_work = 99 * 2 * e * 20.0 + e * (20.0 - e / 2)        # [m^2/s^2] per kg of M
    assert dq.iwt_target_cruise_pct == pytest.approx(100 * cruise_work / 200.0, rel=1e-9)
    assert dq.iwr_pct == pytest.approx(100 * cruise_work / 200.0, rel=1e-9)
    assert dq.within_tolerance is False                        # 19.9 % > 4 %
    # at 1 Hz the samples 21..39 s all fall on +e: one rise of e at 21 s (mean 20 + e/2)
    assert dq.iwr_1hz_pct == pytest.approx(100 * e * (20.0 + e / 2) / 200.0, rel=1e-9)


def test_iwr_reading_says_whether_the_excess_survives_at_one_hz():
    # sub-second corrections while cruising (the case above): outside at 10 Hz, inside at
    # 1 Hz, so the reading names speed content above 1 Hz
    t, vt = _trace()
    vd = vt.copy()
    idx = np.flatnonzero((t > 20.05) & (t < 39.95))
    vd[idx] += 0.01 * np.where(np.arange(idx.size) % 2 == 0, -1.0, 1.0)
    dq = drive_quality(t, vd, vt, mass_kg=1000.0)
    assert iwr_reading(dq).startswith("IWR at 1 Hz +0.10 %, inside the band: the excess is "
                                      "speed content above 1 Hz")
    assert "reference cruises add 19.9 %" in iwr_reading(dq)
    # a driver 2 % fast everywhere: the same excess at 1 Hz (4.04 %), the driver's own
    dq = drive_quality(t, 1.02 * vt, vt, mass_kg=1000.0)
    assert iwr_reading(dq).startswith("IWR at 1 Hz +4.04 %, also outside the band")
    # inside the band: nothing to explain
    assert iwr_reading(drive_quality(t, 1.01 * vt, vt, mass_kg=1000.0)) == ""
