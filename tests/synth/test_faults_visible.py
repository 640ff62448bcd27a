"""Every injected fault is in truth.json with the right signal and span, and is visible in
the file data (default fault mix on the short cycle)."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.io.importer import import_test
from vehval.io.readers import read_raw
from vehval.nomenclature import registry
from vehval.synth.faults import load_fault_specs
from vehval.synth.sensors import expected_measurement, load_sensor_table

pytestmark = pytest.mark.xdist_group("synth")


@pytest.fixture(scope="module")
def ctx(virtual_default):
    v = virtual_default
    test = import_test(v.out.files, v.out.template_path)
    raws = {"facility": read_raw(v.d3), "obd": read_raw(v.obd)}
    return v, test, raws, load_sensor_table()


def _fault(v, kind):
    found = [f for f in v.truth["faults"] if f["kind"] == kind]
    assert len(found) == 1, kind
    return found[0]


def _expected(v, table, f, sig):
    spec = table[f["file"]].channels[f["channel"]]
    off = v.truth["files"][f["file"]]["offset_s"]
    return expected_measurement(spec, v.grid, v.clean[spec.clean], sig.time + off), spec


def _in(sig_time, f):
    return (sig_time >= f["start_s"]) & (sig_time <= f["end_s"])


def test_truth_lists_every_default_fault_with_signal_and_span(virtual_default):
    v = virtual_default
    specs = load_fault_specs("default")
    assert len(v.truth["faults"]) == len(specs) == 11
    table = load_sensor_table()
    dur = v.truth["cycle_duration_s"]
    for spec, f in zip(specs, v.truth["faults"]):
        assert f["kind"] == spec.kind
        if spec.channel:
            assert f["channel"] == spec.channel
            assert f["signal"] == table[f["file"]].channels[spec.channel].name
        if spec.start_frac is not None:
            assert f["start_s"] == pytest.approx(spec.start_frac * dur)
        if spec.end_frac is not None:
            assert f["end_s"] == pytest.approx(spec.end_frac * dur)
        off = v.truth["files"][f["file"]]["offset_s"]
        assert f["true_start_s"] == pytest.approx(f["start_s"] + off)
        assert f["end_s"] > f["start_s"]


def test_clock_offset_and_delay(ctx):
    v, test, _, _ = ctx
    f = _fault(v, "clock_offset")
    assert v.truth["offsets_s"]["obd"] == pytest.approx(-(f["clock_offset_s"] + f["delay_s"]))
    assert v.truth["offsets_s"]["dyno"] == 0.0
    # OBD vehicle speed matches the clean speed only once the truth offset is applied
    sig = test["veh_spd_obd_test"]
    ok = np.isfinite(sig.values)

    def rms(shift):
        ref = np.interp(sig.time[ok] + shift, v.grid, v.clean["veh_spd"])
        return float(np.sqrt(np.mean((sig.values[ok] - ref) ** 2)))

    aligned, raw = rms(v.truth["offsets_s"]["obd"]), rms(0.0)
    # 1 km/h quantisation (rms 0.08 m/s) + 0.05 s snapshot lag on UDDS accelerations
    # (< 0.08 m/s) [m/s]
    assert aligned < 0.15
    assert raw > 2 * aligned


def test_spikes(ctx):
    v, test, _, table = ctx
    f = _fault(v, "spikes")
    sig = test[f["signal"]]
    exp, spec = _expected(v, table, f, sig)
    dev = np.abs(sig.values - exp)
    at = np.isin(np.round(sig.time, 3), f["spike_times_s"])
    assert at.sum() == f["count"]
    assert np.all(dev[at] > 0.5 * f["magnitude"])
    assert np.all(dev[~at] < 0.1 * f["magnitude"])


def test_stuck(ctx):
    v, test, raws, table = ctx
    f = _fault(v, "stuck")
    raw = raws["facility"]
    m = _in(raw.data["Time"], f)
    held = raw.data[f["channel"]][m]
    assert m.sum() > 10 and np.ptp(held) == 0.0
    sig = test[f["signal"]]
    exp, _ = _expected(v, table, f, sig)
    assert np.ptp(exp[_in(sig.time, f)]) > 10 * table["facility"].channels[f["channel"]].noise_si


def test_dropout_written_as_empty_cells(ctx):
    v, _, raws, _ = ctx
    f = _fault(v, "dropout")
    raw = raws["facility"]
    m = _in(raw.data["Time"], f)
    col = raw.data[f["channel"]]
    assert m.sum() > 10 and np.isnan(col[m]).all() and np.isfinite(col[~m]).all()
    lines = v.d3.read_text().splitlines()
    k = int(np.flatnonzero(m)[0]) + 1
    idx = lines[0].split("\t").index(next(h for h in raw.headers if h.startswith(f["channel"])))
    assert lines[k].split("\t")[idx] == ""


def test_gain_error(ctx):
    v, test, _, table = ctx
    f = _fault(v, "gain_error")
    sig = test[f["signal"]]
    exp, _ = _expected(v, table, f, sig)
    big = exp > 0.3 * np.max(exp)
    ratio = np.median(sig.values[big] / exp[big])
    assert ratio == pytest.approx(1 + f["magnitude"], abs=0.01)


def test_offset_drift(ctx):
    v, test, _, table = ctx
    f = _fault(v, "offset_drift")
    sig = test[f["signal"]]
    exp, spec = _expected(v, table, f, sig)
    err = sig.values - exp
    before = sig.time < f["start_s"]
    near_end = sig.time > f["start_s"] + 0.9 * (f["end_s"] - f["start_s"])
    assert abs(np.mean(err[before])) < 0.1 * f["magnitude"]
    assert np.mean(err[near_end]) == pytest.approx(0.95 * f["magnitude"], rel=0.1)


def test_sign_flip(ctx):
    v, test, _, table = ctx
    f = _fault(v, "sign_flip")
    sig = test[f["signal"]]
    exp, _ = _expected(v, table, f, sig)
    assert np.corrcoef(sig.values, exp)[0, 1] < -0.99


def test_wrong_unit_label(ctx):
    v, test, raws, _ = ctx
    f = _fault(v, "wrong_unit")
    raw = raws["facility"]
    i = raw.names.index(f["channel"])
    assert raw.units[i] == f["label_unit"] == "C" and f["true_unit"] == "F"
    # imported as °C, the values are the clean °C temperature expressed in °F
    sig = test[f["signal"]]
    clean_c = np.interp(sig.time, v.grid, v.clean["amb_temp"])
    assert np.median(np.abs(sig.values - (clean_c * 9 / 5 + 32))) < 0.2


def test_out_of_range(ctx):
    v, test, _, _ = ctx
    f = _fault(v, "out_of_range")
    sig = test[f["signal"]]
    m = _in(sig.time, f)
    assert m.sum() >= 1 and np.all(sig.values[m] == pytest.approx(f["magnitude"]))
    lo, hi = registry().spec_of(f["signal"]).range
    assert not lo <= f["magnitude"] <= hi
    assert np.all((sig.values[~m] >= lo) & (sig.values[~m] <= hi))


def test_zero_channel(ctx):
    v, _, raws, _ = ctx
    f = _fault(v, "zero")
    col = raws["obd"].data[f["channel"]]
    assert np.all(col == 0.0)
    assert np.ptp(v.clean["gen_spd_out"]) > 100  # the quantity itself is not zero [rad/s]


def test_truncated_file(ctx):
    v, _, raws, _ = ctx
    f = _fault(v, "truncated")
    raw = raws[f["file"]]
    t = raw.data[raw.time_name]
    assert t[-1] <= f["start_s"] < t[-1] + 2.0
    assert t[-1] == f["last_complete_time_s"] and t.size == f["rows_kept"] < f["rows_total"]
    assert any("truncated" in n for n in raw.notes)
    assert v.obd.read_bytes().endswith(b"\x00")
