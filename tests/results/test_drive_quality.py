"""SAE J2951 metrics on constructed traces with hand-computed values."""

import numpy as np
import pytest

from vehval.constants import MPH_M_PER_S
from vehval.results.drive_quality import drive_quality


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
