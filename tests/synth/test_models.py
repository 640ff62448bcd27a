"""Sensor and fault models of the virtual dyno, without running the simulator."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.errors import ConfigError
from vehval.synth.faults import (
    Fault,
    apply_raw_faults,
    apply_si_faults,
    load_fault_specs,
    resolve_faults,
)
from vehval.synth.sensors import first_order_lag, load_sensor_table, quantise, rng_for
from vehval.synth.writers import write_table

pytestmark = pytest.mark.xdist_group("synth")

ALL_KINDS = {"clock_offset", "stuck", "dropout", "spikes", "gain_error", "offset_drift",
             "sign_flip", "wrong_unit", "out_of_range", "zero", "truncated"}


def test_first_order_lag_step_response():
    # y(t) = 1 - exp(-t/tau) for a unit step; the discretisation is exact for a step input
    dt, tau = 0.1, 0.5
    x = np.r_[0.0, np.ones(50)]
    y = first_order_lag(x, dt, tau)
    t = dt * np.arange(51)
    # sample k (k >= 1) has seen the step for k * dt: y = 1 - exp(-k dt / tau)
    np.testing.assert_allclose(y[1:], 1 - np.exp(-t[1:] / tau), atol=1e-12)
    assert np.array_equal(first_order_lag(x, dt, 0.0), x)


def test_quantise_rounds_to_step_and_keeps_nan():
    out = quantise(np.array([0.12, 0.13, -0.38, np.nan]), 0.25)
    np.testing.assert_array_equal(out[:3], [0.0, 0.25, -0.5])
    assert np.isnan(out[3])


def test_rng_is_keyed_not_sequential():
    a = rng_for(7, "facility", "Engine_Speed").normal(size=3)
    rng_for(7, "facility", "Dyno_Speed").normal(size=100)  # other use in between
    b = rng_for(7, "facility", "Engine_Speed").normal(size=3)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, rng_for(8, "facility", "Engine_Speed").normal(size=3))


def test_sensor_table_maps_required_signals():
    table = load_sensor_table()
    names = {s.name for fs in table.values() for s in fs.channels.values()}
    for n in ("eng_spd_out_test", "veh_spd_test", "eng_spd_out_obd_test", "veh_spd_obd_test",
              "ess_volt_obd_test", "eng_spd_target_obd_test", "gen_spd_out_obd_test",
              "mot_spd_out_obd_test", "mot_trq_out_obd_test", "ess_soc_obd_test",
              "fuel_rate_test", "ess_curr_test", "boost_volt_out_test", "test_phase_test"):
        assert n in names
    units = {s.unit for fs in table.values() for s in fs.channels.values()}
    assert {"mph", "rpm", "ccps", "F", "lbf", "N", "km/h", "%"} <= units


def test_obd_lags_are_snapshot_lags():
    # an OBD PID is a snapshot of the ECU's value: its filter lag is at most 0.05 s and,
    # where the facility measures the same quantity, equal to the facility sensor's (the
    # transport latency is the clock_offset fault's delay_s); see docs/virtual_dyno.md
    table = load_sensor_table()
    facility = {s.clean: s.lag_s for s in table["facility"].channels.values()}
    for s in table["obd"].channels.values():
        assert 0.0 <= s.lag_s <= 0.05, s.channel
        if s.clean in facility and facility[s.clean] <= 0.05:
            assert s.lag_s == facility[s.clean], s.channel


def test_default_faults_cover_every_kind():
    assert {s.kind for s in load_fault_specs("default")} == ALL_KINDS
    assert load_fault_specs("none") == []


@pytest.mark.parametrize("text, fragment", [
    ("- {kind: melt, channel: Engine_Speed}", "kind"),
    ("- {kind: spikes, channel: Engine_Speed}", "needs a magnitude"),
    ("- {kind: stuck, channel: Engine_Speed, colour: red}", "colour"),
    ("- {kind: truncated, file: obd}", "start_s or start_frac"),
    ("- {kind: stuck, channel: Engine_Speed, start_frac: 1.5}", "within 0..1"),
    ("faults: 3", "expected a list"),
    ("- [1, 2]", "expected a mapping"),
    ("version: 2\nfaults: []", "version"),
    ("{kind: [", "not valid YAML"),
])
def test_bad_fault_file_is_a_config_error(tmp_path, text, fragment):
    p = tmp_path / "f.yaml"
    p.write_text(text)
    with pytest.raises(ConfigError, match="f.yaml") as exc:
        load_fault_specs(p)
    assert fragment in str(exc.value)


def test_resolve_rejects_unknown_channel_and_bad_span():
    table = load_sensor_table()
    spans = {"facility": (-10.0, 103.0), "obd": (-4.0, 102.0)}
    with pytest.raises(ConfigError, match="unknown channel 'Nope'"):
        resolve_faults(load_fault_specs([{"kind": "zero", "channel": "Nope"}]), table, 100.0, spans)
    with pytest.raises(ConfigError, match="must be after start"):
        resolve_faults(load_fault_specs([{"kind": "stuck", "channel": "Engine_Speed",
                                          "start_s": 50, "end_s": 40}]), table, 100.0, spans)
    with pytest.raises(ConfigError, match="unknown file"):
        resolve_faults(load_fault_specs([{"kind": "clock_offset", "file": "can",
                                          "magnitude": 1}]), table, 100.0, spans)
    ok = resolve_faults(load_fault_specs([{"kind": "stuck", "channel": "MG2_RPM",
                                           "start_frac": 0.5}]), table, 100.0, spans)
    assert (ok[0].file, ok[0].signal, ok[0].start_s, ok[0].end_s) == ("obd", "mot_spd_out_obd_test",
                                                                      50.0, 102.0)


def _fault(kind, start, end, magnitude=None, **params):
    return Fault(index=0, kind=kind, file="facility", channel="X", signal="x_test",
                 start_s=start, end_s=end, magnitude=magnitude, description="", params=params)


def test_si_and_raw_faults_hand_computed():
    t = np.arange(10.0)
    x = np.arange(10.0) + 1.0  # 1..10
    assert np.array_equal(apply_si_faults(x, t, [_fault("stuck", 3, 5)], 1),
                          [1, 2, 3, 4, 4, 4, 7, 8, 9, 10])
    np.testing.assert_allclose(apply_si_faults(x, t, [_fault("gain_error", 0, 9, 0.1)], 1), 1.1 * x)
    np.testing.assert_allclose(apply_si_faults(x, t, [_fault("offset_drift", 0, 9, 9.0)], 1), x + t)
    assert np.array_equal(apply_si_faults(x, t, [_fault("sign_flip", 8, 9)], 1)[7:], [8, -9, -10])
    assert np.array_equal(apply_si_faults(x, t, [_fault("out_of_range", 2, 2, 99.0)], 1)[1:4],
                          [2, 99, 4])
    f = _fault("spikes", 2, 7, 100.0, count=2)
    y = apply_si_faults(x, t, [f], 1)
    hit = np.flatnonzero(y != x)
    assert hit.size == 2 and np.all(np.abs(y - x)[hit] == 100.0)
    assert list(t[hit]) == f.details["spike_times_s"]
    z = apply_raw_faults(x, t, [_fault("zero", 0, 9), _fault("dropout", 4, 5)])
    assert np.all(z[:4] == 0) and np.isnan(z[4:6]).all() and np.all(z[6:] == 0)


def test_truncated_writer_leaves_partial_last_line(tmp_path):
    cols = [np.arange(5.0), np.arange(5.0) * 2, np.arange(5.0) * 3]
    info = write_table(tmp_path / "a.csv", ["t", "a", "b"], cols, style="csv", decimals=3,
                       truncate_rows=3, nul_padding=8)
    data = (tmp_path / "a.csv").read_bytes()
    assert data.endswith(b"\x00" * 8)
    text = data.rstrip(b"\x00").decode()
    lines = text.split("\n")
    assert lines[:4] == ["t,a,b", "0.0,0.0,0.0", "1.0,2.0,3.0", "2.0,4.0,6.0"]
    assert lines[4] == info["partial_line"] and lines[4].count(",") < 2
    d3 = write_table(tmp_path / "a.txt", ["Time[sec]", "A[N]"], [np.array([-0.0004, 1.0]),
                     np.array([np.nan, -0.0001])], style="d3", decimals=3)
    assert (tmp_path / "a.txt").read_bytes() == b"Time[sec]\tA[N]\r\n0.000\t\r\n1.000\t0.000\r\n"
    assert d3["rows_written"] == 2
