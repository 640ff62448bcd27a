"""A conventional vehicle from EPA list specifications, calibrated on speed-and-fuel tests."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from helpers.epa_lists import HEADER, camry_rows, row, virtual_run, write_list, write_sim_d3
from vehval.calibration.provenance import calibration_tests
from vehval.cli import main
from vehval.constants import MPH_M_PER_S, RPM_RAD_PER_S
from vehval.cycles import load_cycle
from vehval.epa import read_test_car_list
from vehval.epa.specs import specs_from_tests, vehicle_from_specs, warmup_fraction
from vehval.epa.specs_fit import calibrate_specs, dyno_run, predict_runs
from vehval.errors import ConfigError
from vehval.sim.simulate import simulate
from vehval.test import Signal, Test, TestMeta
from vehval.vehicle import load_vehicle


def test_specs_from_list_rows(specs):
    assert specs.gears == 8 and specs.transmission == "A"
    assert specs.displacement_l == pytest.approx(2.487)
    assert specs.rated_power_w == pytest.approx(203 * 745.69987, rel=1e-6)
    assert specs.cold_bag_ratio == pytest.approx(40.9 / 36.1)
    assert len(specs.rows) == 2


def test_specs_refuse_mixed_configurations_and_other_transmissions(tmp_path, monkeypatch):
    monkeypatch.setenv("VEHVAL_UNITS", "us")
    rows = camry_rows() + camry_rows(vid="18-GV2A", weight=3875)
    path = write_list(tmp_path / "mixed.csv", rows, header=HEADER)
    with pytest.raises(ConfigError, match="more than one configuration") as err:
        specs_from_tests(read_test_car_list(path))
    # the message names the test vehicles to choose from, in the units the list gives
    # (was kg to six digits: 1644.27), and this command's options
    assert "18-AV3A config 1: 3625 lb; 18-GV2A config 1: 3875 lb" in str(err.value)
    assert "--vehicle-id" in str(err.value) and "CAMRY" not in str(err.value)
    # a transmission no family models is refused as such before any narrowing is asked for
    other = rows
    for r in other:
        r.update({"Tested Transmission Type Code": "OT", "# of Gears": "1"})
    path = write_list(tmp_path / "ot_mixed.csv", other, header=HEADER)
    with pytest.raises(ConfigError, match="'OT' \\(other\\)"):
        specs_from_tests(read_test_car_list(path))
    # a CVT is a modelled family now (vehval.epa.transmissions)
    cvt = camry_rows()
    for r in cvt:
        r.update({"Tested Transmission Type Code": "CVT", "# of Gears": "1"})
    path = write_list(tmp_path / "cvt.csv", cvt, header=HEADER)
    assert specs_from_tests(read_test_car_list(path)).family == "cvt"


def test_vehicle_from_specs_keeps_n_v_and_sources(specs):
    veh = vehicle_from_specs(specs)
    top = veh.overall_ratios()[-1]
    # engine rpm per mph in top gear is the listed N/V, whatever the rolling radius
    nv = top / veh.driveline.wheel_radius_m * MPH_M_PER_S / RPM_RAD_PER_S
    assert nv == pytest.approx(24.7, rel=1e-9)
    assert veh.body.mass_kg == pytest.approx(3625 * 0.45359237)
    assert "EPA Test Car List 2019" in veh.sources()["body.road_load_c_n_per_mps2"]
    assert all(src.strip() for src in veh.sources().values())
    assert veh.engine.warmup_fuel_fraction == pytest.approx(warmup_fraction(40.9 / 36.1))
    # fuel is exactly inversely proportional to the indicated efficiency
    a = simulate(vehicle_from_specs(specs, 0.36), "hwfet", dt=1.0).summary["fuel_mass_kg"]
    b = simulate(vehicle_from_specs(specs, 0.45), "hwfet", dt=1.0).summary["fuel_mass_kg"]
    assert a / b == pytest.approx(0.45 / 0.36, rel=1e-9)


def test_warmup_fraction_reproduces_the_bag_ratio():
    f = warmup_fraction(1.12, tau=200.0, bag_s=505.0)
    t = np.arange(0.0, 505.0, 0.01)
    assert np.mean(1.0 + f * np.exp(-t / 200.0)) == pytest.approx(1.12, rel=1e-4)
    assert warmup_fraction(0.98) == 0.0



def test_calibration_recovers_a_known_fuel_model(specs):
    truth = vehicle_from_specs(specs, 0.42, 1.3)
    cal = [virtual_run(truth, "udds", "u"), virtual_run(truth, "us06", "s")]
    fit = calibrate_specs(specs, cal, dt=1.0)
    assert fit.indicated_efficiency == pytest.approx(0.42, rel=0.02)
    assert fit.friction_scale == pytest.approx(1.3, abs=0.08)  # the prior pulls towards 1
    assert max(abs(e) for e in fit.errors.values()) < 0.006
    held = predict_runs(fit.model(), [virtual_run(truth, "hwfet", "h")], dt=1.0)
    assert abs(held["h"]) < 0.01
    # the written vehicle names its calibration tests: their figures are in-sample
    assert set(calibration_tests(fit.vehicle())) == {"u", "s"}
    # a record that does not drive (an idle file) has idle fuel, not a fuel economy
    from dataclasses import replace

    idle = replace(cal[0], test_id="idle", distance_m=0.4)
    with pytest.raises(Exception, match=r"test\(s\) idle \(0 m\): drive under 100 m"):
        calibrate_specs(specs, [cal[1], idle], dt=1.0)


def _test_with_soak(v: np.ndarray, fuel: np.ndarray) -> Test:
    t = np.arange(v.size, dtype=float)
    test = Test(meta=TestMeta(test_id="ftp"))
    test.add(Signal.standard("veh_spd_test", t, v))
    test.add(Signal.standard("fuel_rate_test", t, fuel))
    return test


def test_dyno_run_leaves_the_soak_out():
    udds = load_cycle("udds")
    v1 = np.interp(np.arange(0, 1370.0), udds.time_s, udds.speed_mps)
    v = np.r_[v1, np.zeros(600), v1]
    fuel = np.where(v > 0, 1e-3, 2e-4)
    fuel[1370:1970] = 0.0  # engine off in the soak
    run = dyno_run(_test_with_soak(v, fuel))
    # the whole standstill around the 600 s soak (the UDDS ends and starts standing) is
    # left out, but one second either side of it
    assert run.cold and len(run.runs) == 2 and 598.0 <= run.soak_s <= 640.0
    idle_left_out = (run.soak_s - 598.0) * 2e-4
    assert run.fuel_kg == pytest.approx(float(np.sum(fuel)) - idle_left_out, abs=5e-4)
    assert sum(r.time_s.size for r in run.runs) == v.size - run.soak_s
    assert run.idle_fuel_kg_s == pytest.approx(2e-4)
    warm = dyno_run(_test_with_soak(v1, np.where(v1 > 0, 1e-3, 2e-4)))
    assert not warm.cold and len(warm.runs) == 1


def test_dyno_run_counts_the_test_fuel_as_the_models_fuel_energy():
    """A dyno test on E10 fitted by a model burning certification E0: the measured mass
    counts as E0 of the same energy (the indicated efficiency came out 4 % low: 42.8 %
    instead of 44.6 % on the D3 Camry, the EPA figures predicted 5-8 % low)."""
    from vehval.epa.specs import model_fuel_lhv
    from vehval.fuels import table_fuel

    udds = load_cycle("udds")
    v = np.interp(np.arange(0, 1370.0), udds.time_s, udds.speed_mps)
    fuel = np.where(v > 0, 1e-3, 2e-4)
    base = dyno_run(_test_with_soak(v, fuel), model_lhv_j_per_kg=model_fuel_lhv())
    assert base.fuel_note == ""                      # no fuel declared: nothing to count
    lhv = {n: table_fuel(n).lhv_j_per_kg for n in ("gasoline_e10", "gasoline_e0")}
    for name, ratio in (("gasoline_e10", lhv["gasoline_e10"] / lhv["gasoline_e0"]),
                        ("gasoline_e0", 1.0)):
        test = _test_with_soak(v, fuel)
        test.meta.fuel = name
        run = dyno_run(test, model_lhv_j_per_kg=model_fuel_lhv())
        assert run.fuel_kg == pytest.approx(base.fuel_kg * ratio, rel=1e-12)
        assert run.idle_fuel_kg_s == pytest.approx(base.idle_fuel_kg_s * ratio, rel=1e-12)
        assert ("mass x 0.96" in run.fuel_note) == (name == "gasoline_e10")
    assert dyno_run(test).fuel_kg == base.fuel_kg   # no model fuel given: the mass as measured



def test_cli_builds_calibrates_and_marks_in_sample(tmp_path, specs, capsys):
    lists = write_list(tmp_path / "19tstcar.csv", camry_rows(), header=HEADER)
    truth = vehicle_from_specs(specs, 0.43, 1.1, cold_start=False)
    for name, cyc in (("t1", "udds"), ("t2", "us06"), ("t3", "hwfet")):
        write_sim_d3(tmp_path / f"{name} Test Data.txt", truth, cyc)
    tmpl = tmp_path / "t.yaml"
    tmpl.write_text("template_version: 1\nfuel: gasoline_e0\nfiles:\n- source: dyno\n"
                    "  format: d3\n  time: {column: Time}\n  channels:\n"
                    "    Eng_FuelFlow_Direct_DI: {name: fuel_rate_test, unit: ccps}\n"
                    "    Dyno_Spd: {name: veh_spd_test, unit: mph}\n", encoding="utf-8")
    out = tmp_path / "sedan.yaml"
    args = ["epa", "vehicle", str(lists), "--make", "MAKER", "--model", "SEDAN XLE",
            "--year", "2019", "--calibrate", str(tmp_path / "t1 Test Data.txt"),
            "--calibrate", str(tmp_path / "t2 Test Data.txt"),
            "--predict", str(tmp_path / "t3 Test Data.txt"), "-t", str(tmpl), "--dt", "1",
            "-o", str(out), "--json"]
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    marks = {t["test"]: t["in_sample"] for t in doc["tests"]}
    assert list(marks.values()) == [True, True, False]
    held = [t for t in doc["tests"] if not t["in_sample"]][0]
    assert abs(held["error"]) < 0.02  # the held-out HWFET of the virtual car
    assert doc["calibration"]["indicated_efficiency"] == pytest.approx(0.43, rel=0.05)
    veh = load_vehicle(out)
    assert len(calibration_tests(veh)) == 2
    assert math.isfinite(veh.engine_control.idle_fuel_rate_g_per_s)
    # no template: refused with the option to give
    assert main([a for a in args if a not in ("-t", str(tmpl))][:-1]) == 2
    assert "give the import template" in capsys.readouterr().err
    # the text output: the weight in the system's unit, the efficiency in % (was 0.4284)
    text = args[:args.index("--predict")] + ["-t", str(tmpl), "--dt", "1", "-o",
                                             str(tmp_path / "s2.yaml")]
    assert main(["--units", "us", *text]) == 0
    out = capsys.readouterr().out
    assert re.search(r": \d{4} lb, ", out), out
    assert re.search(r"indicated efficiency (4[0-6]\.\d) %", out), out


def _specs_of(tmp_path, rows, name="l.csv"):
    return specs_from_tests(read_test_car_list(write_list(tmp_path / name, rows, header=HEADER)))


def test_e85_is_not_gasoline(tmp_path):
    """An E85 row names the gasoline it is blended with; it was simulated and judged as a
    gasoline test (a 2016 EQUINOX FWD's E85 HWFET at +19 % against a gasoline model)."""
    from vehval.epa.procedures import is_gasoline, plan_for

    assert not is_gasoline("E85 (85% Ethanol 15% EPA Unleaded Gasoline)")
    for fuel in ("Tier 2 Cert Gasoline", "Tier 3 E10 Premium Gasoline (9 RVP @Low Alt.)",
                 "CARB Phase II Gasoline", ""):
        assert is_gasoline(fuel), fuel
    assert not is_gasoline("Federal Cert Diesel 7-15 PPM Sulfur")
    e85 = read_test_car_list(write_list(tmp_path / "e.csv", [row(
        fuel=("19", "E85 (85% Ethanol 15% EPA Unleaded Gasoline)"))]))[0]
    proc, why = plan_for(e85)
    assert proc is None and "not gasoline" in why


def test_specs_refuse_what_the_conventional_model_is_not(tmp_path):
    """A hybrid by name ('ActiveHybrid 5' has an 8-speed automatic), a plug-in by its
    charge-depleting rows, a diesel or E85-only configuration: each was built as a
    gasoline conventional car without a word."""
    with pytest.raises(ConfigError, match="'HYBRID' in the model name"):
        _specs_of(tmp_path, camry_rows(model="ActiveHybrid 5"))
    with pytest.raises(ConfigError, match="'HEV' in the model name"):
        _specs_of(tmp_path, camry_rows(model="Fusion (HEV)"))
    _specs_of(tmp_path, camry_rows(model="CHEVROLET SEDAN"))  # HEV inside a word: a car
    plug = camry_rows()
    plug.append({**plug[0], "Test Procedure Cd": "81", "Test Number": "CD1",
                 "Test Procedure Description": "Charge Depleting UDDS"})
    with pytest.raises(ConfigError, match="charge-depleting test CD1"):
        _specs_of(tmp_path, plug)
    for fuel in (("20", "Federal Cert Diesel 7-15 PPM Sulfur"),
                 ("19", "E85 (85% Ethanol 15% EPA Unleaded Gasoline)")):
        with pytest.raises(ConfigError, match="no gasoline: the model from specs is a "
                                              "spark-ignition engine"):
            _specs_of(tmp_path, camry_rows(fuel=fuel))
    # a flexible-fuel configuration tested on both: the gasoline rows make the cold start
    ffv = camry_rows() + [{**r, "Test Number": r["Test Number"] + "E", "FE Bag 1": "20",
                            "Test Fuel Type Description": "E85 (85% Ethanol 15% EPA "
                            "Unleaded Gasoline)"} for r in camry_rows()]
    assert _specs_of(tmp_path, ffv).cold_bag_ratio == pytest.approx(40.9 / 36.1)


def test_specs_leave_out_cold_co_rows(tmp_path):
    """Cold CO rows carry the road load raised for -7 degC (a 2019 Kia Soul: A 28.83 and
    31.71 lbf in one configuration), which refused every configuration with a cold CO test
    as 'more than one configuration'."""
    rows = camry_rows()
    rows.append({**rows[0], "Test Procedure Cd": "11", "Test Number": "C1",
                 "Test Procedure Description": "Cold CO", "Test Fuel Type Cd": "26",
                 "Test Fuel Type Description": "Cold CO Regular (Tier 2)",
                 "Target Coef A (lbf)": str(26.508 * 1.1), "FE Bag 1": "20.0"})
    specs = _specs_of(tmp_path, rows)
    assert specs.target_a_n == pytest.approx(26.508 * 4.4482216, rel=1e-6)
    assert len(specs.rows) == 2 and not any("C1" in r for r in specs.rows)
    assert specs.cold_bag_ratio == pytest.approx(40.9 / 36.1)


def test_specs_refuse_implausible_or_missing_values(tmp_path):
    """A rated power of 1 hp (a 2019 Golf GTI row), an N/V of 4.2 rpm/mph (a 2019 Urus row:
    252 rpm at 60 mph) and a missing displacement (the 2017 list) are named with the row."""
    rows = camry_rows()
    for r in rows:
        r["Rated Horsepower"] = "1"
    with pytest.raises(ConfigError, match=r"rated power 0.7 kW for 2.487 L .*typing error"):
        _specs_of(tmp_path, rows)
    rows = camry_rows()
    for r in rows:
        r["N/V Ratio"] = "4.2"
    with pytest.raises(ConfigError, match=r"N/V 4.2 rpm/mph puts the engine at 252 rpm"):
        _specs_of(tmp_path, rows)
    rows = camry_rows()
    for r in rows:
        r["Test Veh Displacement (L)"] = ""
    with pytest.raises(ConfigError, match=r"F1 \(l.csv:2\): no displacement \[L\] \('Test Veh "
                                          r"Displacement \(L\)' empty or absent"):
        _specs_of(tmp_path, rows)
    # several weights under one test vehicle of a list without configuration numbers
    rows = camry_rows() + camry_rows(weight=3875)
    for r in rows:
        r["Test Veh Configuration #"] = ""
    with pytest.raises(ConfigError, match="the list has no configuration number"):
        _specs_of(tmp_path, rows)


def test_cli_vehicle_chooses_a_configuration(tmp_path, capsys):
    """One test vehicle at two road loads (a 2019 BMW 540i, configurations 0 and 2) could not
    be built: the message asked for --vehicle-id, which selected both again."""
    rows = camry_rows() + camry_rows(cfg="2", target=(25.0, 0.1976, 0.00733))
    for r in rows[2:]:
        r["Test Number"] += "b"
    lists = write_list(tmp_path / "19tstcar.csv", rows, header=HEADER)
    args = ["epa", "vehicle", str(lists), "--make", "MAKER", "--model", "SEDAN XLE",
            "--year", "2019", "--vehicle-id", "18-AV3A", "-o", str(tmp_path / "v.yaml")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "18-AV3A config 1:" in err and "18-AV3A config 2:" in err and "--config N" in err
    assert main([*args, "--config", "7"]) == 2
    assert "--config 7: no selected row has it (there are: 1, 2)" in capsys.readouterr().err
    assert main([*args, "--config", "2", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["specs"]["target_a_n"] == pytest.approx(25.0 * 4.4482216, rel=1e-6)
    assert all("b (" in r for r in doc["specs"]["rows"])


def test_cli_tests_shows_whole_ids_transmission_and_fuel(tmp_path, capsys):
    """The table cut vehicle IDs to 9 characters ('PS7N0AU01' of 'PS7N0AU01AC'), which then
    matched nothing in --vehicle-id or vehicle=; it now also shows what `epa vehicle` needs
    (transmission and gears, test fuel)."""
    rows = camry_rows(vid="PS7N0AU01AC")
    lists = write_list(tmp_path / "19tstcar.csv", rows, header=HEADER)
    assert main(["epa", "tests", str(lists), "--model", "SEDAN XLE"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1].split()[1:6] == ["PS7N0AU01AC", "1", "MFR", "ftp75", "A8"]
    assert out[1].split()[6] == "gas"


def test_cli_vehicle_without_tests_says_it_is_not_calibrated(tmp_path, capsys):
    """Without --calibrate the generic start values make the fuel model (16 cars of the
    lists: FTP-75 -18..+19 %, HWFET -24..+4 %) and nothing said so."""
    lists = write_list(tmp_path / "19tstcar.csv", camry_rows(), header=HEADER)
    out = tmp_path / "v.yaml"
    assert main(["epa", "vehicle", str(lists), "--make", "MAKER", "--model", "SEDAN XLE",
                 "--year", "2019", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "fuel model not calibrated (no --calibrate test)" in text
    assert "generic technology coefficients" in text and "a naturally aspirated spark-ignition engine and an" in text
    assert "automatic gearbox: indicated efficiency" in text
    assert "fuel model not calibrated" in load_vehicle(out).description


def test_an_implausible_fitted_map_is_named(specs):
    """The fit accepts an indicated efficiency anywhere in 0.1-0.6; a map whose best brake
    efficiency no spark-ignition engine reaches (fuel in the wrong unit, another car's list
    row) was written and used without a word. Its best brake efficiency is now stated and
    flagged outside 20-45 %."""
    from vehval.epa.specs_fit import efficiency_note
    from vehval.vehicle.maps import peak_brake_efficiency

    eff, rpm, nm = peak_brake_efficiency(vehicle_from_specs(specs, 0.43, 1.0).engine)
    assert 0.30 < eff < 0.42 and rpm >= 700 and nm > 0
    assert efficiency_note(vehicle_from_specs(specs, 0.43, 1.0)) == ""
    note = efficiency_note(vehicle_from_specs(specs, 0.59, 0.5))
    assert "best brake efficiency is" in note and "outside the 20-45 %" in note
    assert "outside the 20-45 %" in efficiency_note(vehicle_from_specs(specs, 0.15, 2.0))


def test_splits_name_what_they_need():
    from vehval.epa.specs_fit import all_splits

    with pytest.raises(ConfigError, match=r"--splits 2: each split calibrates on 2 test\(s\) "
                                          r"and holds out the others, so it needs between 1 "
                                          r"and 1 calibration tests with 2 tests given"):
        all_splits(None, [object(), object()], 2)  # refused before anything is fitted
    with pytest.raises(ConfigError, match="a split holds out at least one test"):
        all_splits(None, [object()], 1)
