"""Which tests a vehicle file was calibrated on, read back from its provenance texts."""

from __future__ import annotations

from vehval.calibration import Provenance, vehicle_with_values
from vehval.calibration.provenance import calibration_tests, ids_in_source, in_sample
from vehval.vehicle import load_vehicle


def test_ids_in_source_reads_both_formats():
    new = Provenance(by="vehval calibrate", tests=["t1", "t2"], objective="objective",
                     start_value=1.0, best_value=0.5, method="grid",
                     start={"controller.soc_gain_w": 1.0},
                     ranges={"controller.soc_gain_w": "grid 1, 2"}, dt=0.2,
                     holdout=["t3"]).text("controller.soc_gain_w")
    assert ids_in_source(new) == ["t1", "t2"]  # the held-out t3 is not in-sample
    old = ("calibrated by vehval epa calibrate on the EPA Test Car List tests GTYX1, GTYX2 "
           "(grid 1, 2; RMS 3 % -> 1 %)")
    assert ids_in_source(old) == ["GTYX1", "GTYX2"]
    # a folded YAML string (line breaks inside the list) reads the same
    assert ids_in_source("calibrated by vehval epa calibrate on the EPA Test Car List "
                           "tests A1,\n  B2 (grid)") == ["A1", "B2"]
    assert ids_in_source("calibrated by vehval epa vehicle on tests 61811011 Test Data, "
                         "61811012 Test Data on 2026-01-02: RMS") == [
        "61811011 Test Data", "61811012 Test Data"]  # ids with spaces
    assert ids_in_source("engineering estimate; fitted by least squares") == []
    assert ids_in_source("2004 value, calibrated elsewhere") == []


def test_prius_2016_calibration_tests():
    cal = calibration_tests(load_vehicle("prius_2016"))
    mfr = {"GTYX10037847", "GTYX10037851", "GTYX10038687", "GTYX10038681", "GTYX10038682",
           "GTYX10038683"}
    ftp = {"GTYX10037847", "GTYX91002968", "GTYX10038681", "GTYX91002962"}
    assert set(cal) == mfr | ftp
    assert "controller.soc_gain_w" in cal["GTYX10037851"]
    assert cal["GTYX91002968"] == ["controller.cold_start_engine_on_s",
                                   "controller.cold_start_engine_power_w",
                                   "engine.warmup_fuel_fraction"]
    assert calibration_tests(load_vehicle("prius_2004")) == {}


def test_written_calibration_is_read_back():
    veh = load_vehicle("prius_2004")
    prov = Provenance(by="vehval calibrate", tests=["run_a"], objective="objective",
                      start_value=2.0, best_value=1.0, method="grid",
                      start={"controller.soc_gain_w": veh.controller.soc_gain_w},
                      ranges={"controller.soc_gain_w": "grid 1, 2"}, dt=1.0, holdout=["run_b"])
    cal = vehicle_with_values(veh, {"controller.soc_gain_w": 20000.0}, prov.text)
    assert calibration_tests(cal) == {"run_a": ["controller.soc_gain_w"]}
    assert in_sample(cal, "run_a") and not in_sample(cal, "run_b")
    assert calibration_tests(cal.model_dump()) == calibration_tests(cal)
