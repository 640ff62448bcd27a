"""Round trip: import a fault-free virtual test and recover the clean signals within the
stated sensor model (noise, calibration, lag, quantisation), and the offsets from truth."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.io.importer import import_test
from vehval.synth.sensors import expected_measurement, load_sensor_table

pytestmark = pytest.mark.xdist_group("synth")


def _tolerances(truth: dict, ch: str) -> tuple[float, float]:
    """(sigma [SI], quantisation step [SI]) of a channel: its quantisation is the coarser of
    the sensor's step and the file's written decimals."""
    info = truth["channels"][ch]
    dec = truth["files"][info["file"]]["decimals"]
    scale = info["quant_si"] / info["quant_raw"] if info["quant_raw"] else None
    if scale is None:
        raise AssertionError(f"{ch}: quant_raw must be > 0 in the sensor table")
    return info["noise_si"], max(info["quant_si"], 10.0 ** -dec * scale)


def test_none_run_has_no_faults_and_zero_offsets(virtual_none):
    t = virtual_none.truth
    assert t["faults"] == []
    assert t["synthetic"] is True and t["faults_setting"] == "none"
    assert all(v == 0.0 for v in t["offsets_s"].values())
    assert all(f["offset_s"] == 0.0 and not f["truncated"] for f in t["files"].values())
    assert all(c["header_unit"] == c["true_raw_unit"] for c in t["channels"].values())


def test_roundtrip_recovers_clean_signals(virtual_none):
    v = virtual_none
    test = import_test(v.out.files, v.out.template_path)
    # the generated template declares the virtual test and its generating cycle
    assert test.meta.synthetic is True and test.meta.cycle == v.truth["cycle"] == "udds240"
    table = load_sensor_table()
    checked = 0
    for label, fs in table.items():
        offset = v.truth["files"][label]["offset_s"]
        for ch, spec in fs.channels.items():
            sig = test[spec.name]
            assert sig.source == fs.source
            expected = expected_measurement(spec, v.grid, v.clean[spec.clean], sig.time + offset)
            err = sig.values - expected
            sigma, q = _tolerances(v.truth, ch)
            # Gaussian noise: E|e| = 0.8 sigma, so 3 sigma + q/2 on the mean is a loose bound;
            # every sample within 6 sigma + q/2 (P(|z| > 6) ~ 2e-9 per sample); 1e-9 relative
            # slack for float conversions (affine °F, volumetric fuel flow)
            slack = 1e-9 * (1.0 + np.max(np.abs(expected)))
            assert np.all(np.isfinite(err)), ch
            assert np.mean(np.abs(err)) <= 3 * sigma + q / 2 + slack, (ch, np.mean(np.abs(err)))
            assert np.max(np.abs(err)) <= 6 * sigma + q / 2 + slack, (ch, np.max(np.abs(err)))
            checked += 1
    assert checked == sum(len(fs.channels) for fs in table.values()) == 22


def test_noise_is_present_and_matches_the_spec(virtual_none):
    """The error is not zero: the stated noise is really there (std within 15 % for channels
    whose noise dominates their quantisation)."""
    v = virtual_none
    test = import_test(v.out.files, v.out.template_path)
    table = load_sensor_table()
    for ch in ("Dyno_Tractive_Effort", "Wheel_Torque", "Hioki_Batt_Current", "Engine_Torque"):
        spec = table["facility"].channels[ch]
        sig = test[spec.name]
        err = sig.values - expected_measurement(spec, v.grid, v.clean[spec.clean], sig.time)
        assert np.std(err) == pytest.approx(spec.noise_si, rel=0.15), ch


def test_timing_looks_like_the_real_systems(virtual_none):
    v = virtual_none
    test = import_test(v.out.files, v.out.template_path)
    t_d3 = test["veh_spd_test"].time
    steps = np.round(np.diff(t_d3), 3)
    assert t_d3[0] == -10.0
    assert set(np.unique(steps)) <= {0.099, 0.1} and np.mean(steps == 0.1) > 0.99
    t_obd = test["veh_spd_obd_test"].time
    d = np.diff(t_obd)
    assert 0.95 < np.median(d) < 1.05 and np.std(d) > 0.01  # ~1 Hz polling with jitter
