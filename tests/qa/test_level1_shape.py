"""QA level 1 shape checks on constructed quantised and slow traces (1 Hz OBD-like).

Each case states what a real sensor would do: a quantised slow ramp raises nothing, a real
spike on it is found, a truly stuck sensor is found.
"""

import numpy as np

from vehval.qa.findings import Kind, Severity
from vehval.qa.level1 import run_level1
from vehval.qa.level1_shape import resolution
from vehval.test import Signal, Test


def _warn(found, name, kind):
    return [f for f in found if f.signal == name and f.kind == kind
            and f.severity != Severity.INFO]


def _temp_ramp(n=600, rate=0.1 / 60.0, q=0.1, seed=3):
    """Battery temperature at 1 Hz, 0.1 degC resolution, rising 0.1 degC a minute, with a
    little sensor noise before the quantiser (it toggles between codes near a boundary)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    true = 25.0 + rate * t + 0.01 * rng.standard_normal(n)
    return t, np.round(true / q) * q


def _test(*signals):
    return Test([Signal.standard(name, t, v, source="obd") for name, t, v in signals])


def test_resolution_is_inferred_from_the_steps():
    t, v = _temp_ramp()
    assert resolution(v) == np.float64(0.1) or abs(resolution(v) - 0.1) < 1e-9
    # a thermistor table's slightly unequal counts still count as one resolution
    codes = np.cumsum(np.r_[0.0, np.tile([0.0976, 0.0, 0.109, 0.0, 0.1015, 0.0], 30)])
    assert 0.09 < resolution(20.0 + codes) < 0.11
    # a continuous noisy signal has none
    assert resolution(np.random.default_rng(1).standard_normal(500)) == 0.0


def test_quantised_slow_ramp_raises_nothing():
    t, v = _temp_ramp()
    t2, v2 = _temp_ramp(seed=4)
    found = run_level1(_test(("ess_temp_bt1_test", t, v), ("ess_temp_bt2_test", t2, v2 + 1.3)))
    bad = [f for f in found if f.severity != Severity.INFO]
    assert bad == [], [f.message for f in bad]


def test_one_count_steps_of_a_1hz_soc_are_not_spikes():
    # SOC in counts of 1/255, moving up and down with the current: +-1 count blips
    rng = np.random.default_rng(5)
    t = np.arange(400, dtype=float)
    soc = 0.55 + 0.03 * np.sin(t / 60.0) + 0.004 * rng.standard_normal(t.size)
    q = 1.0 / 255.0
    soc = np.round(soc / q) * q
    found = run_level1(_test(("ess_soc_obd_test", t, soc)))
    assert _warn(found, "ess_soc_obd_test", Kind.SPIKE) == []


def test_real_spike_on_a_quantised_ramp_is_found():
    t, v = _temp_ramp()
    v = v.copy()
    v[300] += 1.0                               # ten counts for one sample: a sensor spike
    found = run_level1(_test(("ess_temp_bt1_test", t, v)))
    hits = _warn(found, "ess_temp_bt1_test", Kind.SPIKE)
    assert [h.start_s for h in hits] == [300.0]
    assert hits[0].numbers["threshold"] >= 0.25 - 1e-9     # at least 2.5 counts of 0.1


def test_truly_stuck_slow_sensor_is_found():
    # the temperature normally moves 1 count a minute; frozen for 5 minutes while the same
    # temperature from another source moves 5 counts: stuck (error). A one-minute hold of a
    # count, the ordinary way of this signal, is not judged.
    t, v = _temp_ramp(n=900)
    _, other = _temp_ramp(n=900, seed=8)
    v = v.copy()
    v[300:600] = v[300]
    found = run_level1(_test(("ess_temp_test", t, v), ("ess_temp_obd_test", t, other)))
    hits = [f for f in found if f.signal == "ess_temp_test" and f.kind == Kind.STUCK]
    assert [f.severity for f in hits] == [Severity.ERROR]
    assert hits[0].start_s <= 301 and hits[0].end_s >= 595
    assert not [f for f in found if f.signal == "ess_temp_obd_test" and f.kind == Kind.STUCK]


def test_stuck_duplicate_is_an_error_but_another_sensor_position_is_not_a_duplicate():
    t, v = _temp_ramp(n=900, rate=0.5 / 60.0)   # 5 counts a minute
    stuck = v.copy()
    stuck[200:400] = stuck[200]
    # the same quantity from another source: a duplicate, error
    found = run_level1(_test(("ess_temp_test", t, stuck), ("ess_temp_obd_test", t, v)))
    assert [f.severity for f in found if f.signal == "ess_temp_test" and f.kind == Kind.STUCK] \
        == [Severity.ERROR]
    # bt1 / bt2 are two positions in the pack: bt2 moving says nothing about bt1
    t2, slow = _temp_ramp(n=900, rate=0.05 / 60.0)
    found = run_level1(_test(("ess_temp_bt1_test", t2, slow), ("ess_temp_bt2_test", t, v)))
    assert [f for f in found if f.kind == Kind.STUCK] == []


def test_one_hz_fuel_rate_excursion_inside_its_range_is_not_a_sensor_spike():
    # a 1 Hz point sample of a pulsating flow: one sample twice its neighbours, inside the
    # range the flow takes elsewhere, may be real (info); a value far beyond it is a spike
    rng = np.random.default_rng(2)
    t = np.arange(600, dtype=float)
    fuel = 1e-3 * (0.6 + 0.5 * (np.sin(t / 40.0) > 0) + 0.02 * rng.standard_normal(t.size))
    fuel[np.arange(20, 600, 50)] += 1.2e-3                 # short tip-ins within the range
    fuel[np.arange(45, 600, 100)] = 1.9e-3
    ok = run_level1(_test(("fuel_rate_test", t, fuel)))
    assert _warn(ok, "fuel_rate_test", Kind.SPIKE) == []
    assert [f for f in ok if f.kind == Kind.SPIKE]          # seen, reported as info
    bad = fuel.copy()
    bad[333] = 9e-3                                         # far beyond anything it does
    found = run_level1(_test(("fuel_rate_test", t, bad)))
    assert [f.start_s for f in _warn(found, "fuel_rate_test", Kind.SPIKE)] == [333.0]


def _hybrid_throttle(stuck_while_running=False, n=600, seed=5):
    """1 Hz hybrid log: the pedal varies all along; the engine stops for 12 s every minute
    (first sample of each stop still spinning down at 200 rpm, as the Prius c OBD logs
    show); the throttle follows the pedal while the engine runs and rests at its parking
    position 16.08 % while it is stopped."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    pedal = np.round((20.0 + 10.0 * np.sin(t / 7.0) + rng.standard_normal(n)) / 0.392) * 0.392
    eng = np.full(n, 1500.0 * np.pi / 30.0) + rng.standard_normal(n)
    throttle = np.round((pedal * 0.9 + 2.0) / 0.392) * 0.392
    for k in range(30, n - 20, 60):
        eng[k:k + 12] = 0.0
        eng[k] = 200.0 * np.pi / 30.0
        throttle[k:k + 12] = 16.08
    if stuck_while_running:
        throttle[300:312] = throttle[300]       # engine runs over 300..311
    return _test(("eng_pos_throttle_test", t, throttle), ("drv_pos_accel_test", t, pedal),
                 ("eng_spd_out_test", t, eng))


def test_throttle_at_rest_while_a_hybrids_engine_is_stopped_is_not_stuck():
    # the pedal drives the motor while the engine is stopped: a throttle holding its rest
    # position then is not a stuck sensor, even with a spin-down sample in the hold
    found = run_level1(_hybrid_throttle())
    assert _warn(found, "eng_pos_throttle_test", Kind.STUCK) == []
    # the same hold while the engine runs is still found
    found = run_level1(_hybrid_throttle(stuck_while_running=True))
    hits = _warn(found, "eng_pos_throttle_test", Kind.STUCK)
    assert [(f.start_s, f.end_s) for f in hits] == [(300.0, 311.0)]
    assert hits[0].related == ["drv_pos_accel_test"]


def test_whole_kpa_toggles_of_a_barometric_pid_are_not_spikes():
    # SAE J1979 PID 0x33 gives whole kPa: 99 -> 100 -> 99 over one sample is one count, but
    # six steps are too few for the step-based resolution; the raw numbers tell the count
    t = np.arange(300.0)
    kpa = np.full(t.size, 99.0)
    kpa[[120, 150, 200]] = 100.0

    def baro(values):
        return Test([Signal.standard("amb_pres_test", t, values * 1e3, source="obd",
                                     raw_unit="kPa")])

    assert _warn(run_level1(baro(kpa)), "amb_pres_test", Kind.SPIKE) == []
    # a 5 kPa excursion (five counts) on the same trace is still a spike
    kpa[250] = 104.0
    hits = _warn(run_level1(baro(kpa)), "amb_pres_test", Kind.SPIKE)
    assert [h.start_s for h in hits] == [250.0]
