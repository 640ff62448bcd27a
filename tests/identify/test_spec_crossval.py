"""Declared specification vs generic scaling, another car's round trip, cross-validation,
prediction intervals and the bad-input lines (virtual tests of a 5-speed petrol car)."""

import json

import numpy as np
import pytest

from vehval.cli import main
from vehval.cycles import load_cycle
from vehval.errors import ConfigError
from vehval.identify import identify_conventional, load_traces, predict_trace
from vehval.identify.spec import load_spec, resolve, tyre_radius_m
from vehval.synth.conventional import make_conventional_test
from vehval.vehicle import load_vehicle
from vehval.vehicle.scaling import scale_engine_map

pytestmark = pytest.mark.slow


def another_car():
    """A 5-speed car with a smaller, faster engine, lighter than the packaged Cruze."""
    ref = load_vehicle("cruze_diesel_2014")
    veh = ref.model_copy(deep=True)
    e = veh.engine
    spd, trq, fuel, tmax = scale_engine_map(e.speed_rpm, e.torque_nm, e.fuel_rate_g_per_s,
                                            e.max_torque_nm, 1.4, 0.55)
    e.speed_rpm, e.torque_nm, e.fuel_rate_g_per_s, e.max_torque_nm = spd, trq, fuel, tmax
    e.max_power_w, e.max_speed_rpm = 0.55 * 1.4 * e.max_power_w, 1.4 * e.max_speed_rpm
    e.idle_speed_rpm, e.fire_speed_rpm = 750.0, 375.0
    e.inertia_kg_m2 = 0.15
    veh.engine_control.idle_fuel_rate_g_per_s = 0.22
    veh.engine_control.fuel_cut_min_speed_rpm = 1300.0
    g = veh.gearbox
    g.ratios = [17.5, 10.0, 6.6, 4.7, 3.6]
    g.upshift_speed_mps, g.upshift_speed_full_load_mps = [4.5, 8.5, 12.5, 17.5], [6.0, 14.0, 22.0, 28.0]
    g.downshift_speed_mps, g.downshift_speed_full_load_mps = [3.0, 6.5, 10.0, 14.0], [4.0, 10.0, 17.0, 22.0]
    veh.converter.lockup_speed_mps = [60.0, 7.0, 9.0, 12.0, 16.0]
    veh.body.mass_kg = 1350.0
    veh.body.road_load_a_n, veh.body.road_load_b_n_per_mps = -40.0, 8.5
    veh.driveline.wheel_radius_m = 0.30
    veh.name = "virtual_petrol_5"
    return type(veh).model_validate(veh.model_dump())


def declared_for(veh) -> dict:
    e = veh.engine
    return load_spec(None, {"rated_power_kw": e.max_power_w / 1e3, "max_speed_rpm": e.max_speed_rpm,
                            "peak_torque_nm": max(e.max_torque_nm), "fuel": "gasoline",
                            "wheel_radius_m": veh.driveline.wheel_radius_m,
                            "gears": len(veh.gearbox.ratios), "test_mass_kg": veh.body.mass_kg})


@pytest.fixture(scope="module")
def car(tmp_path_factory):
    veh = another_car()
    files, tpl = {}, None
    for cyc in ("udds", "wltc3b", "hwfet"):
        info = make_conventional_test(veh, load_cycle(cyc), seed=5,
                                      outdir=tmp_path_factory.mktemp(cyc))
        files[cyc] = info["files"][0]
        tpl = info["template"]
    traces = load_traces([files["udds"], files["wltc3b"]], tpl)
    return veh, files, tpl, traces


def test_tyre_radius_and_spec_refusals(tmp_path):
    assert tyre_radius_m("225/50 R17") == pytest.approx(0.97 * (17 * 0.0254 / 2 + 0.1125))
    with pytest.raises(ConfigError, match="width/aspect"):
        tyre_radius_m("R17")
    bad = tmp_path / "s.yaml"
    bad.write_text("rated_power_kw: 100\nhorsepower: 3\n")
    with pytest.raises(ConfigError, match="unknown key 'horsepower'"):
        load_spec(bad)
    bad.write_text("gears: 40\n")
    with pytest.raises(ConfigError, match="gears 40 is outside"):
        load_spec(bad)
    # an option overrides the file, and says so
    bad.write_text("gears: 6\nsources: {gears: data sheet}\n")
    d = load_spec(bad, {"gears": 5})
    assert d["gears"][0] == 5 and d["gears"][1] == "option"


def test_generic_scaling_names_every_value_and_uses_the_declared_ones():
    a = resolve({}, "diesel", 40e3)
    assert set(a.generic()) >= {"rated_power_kw", "displacement_l", "peak_torque_nm",
                                "wheel_radius_m", "engine_inertia_kg_m2", "motoring_torque_nm",
                                "gearbox_efficiency", "accessory_power_w", "full_load",
                                "driven_axle_loss_share", "rated_speed_rpm", "max_speed_rpm"}
    assert a.max_power_w == pytest.approx(1.25 * 40e3 / 0.93)
    d = resolve(load_spec(None, {"displacement_l": 1.6, "rated_power_kw": 90.0}), "gasoline", 1.0)
    assert d.max_power_w == 90e3 and "rated_power_kw" not in d.generic()
    assert d.engine_inertia_kg_m2 == pytest.approx(0.12 * 1.6)
    assert max(d.full_load_nm) == pytest.approx(12e5 * 1.6e-3 / (4 * np.pi), rel=1e-3)
    # the curve never asks for more than the rated power
    w = np.asarray(d.full_load_rpm) * np.pi / 30
    assert np.all(np.asarray(d.full_load_nm) * w <= 90e3 * 1.0001)


def test_another_car_round_trips_with_its_declared_spec(car):
    veh, _, _, traces = car
    idf = identify_conventional(traces, "rt", declared=declared_for(veh))
    got = np.asarray(idf.vehicle.gearbox.ratios)
    assert got.size == 5
    np.testing.assert_allclose(got[1:], veh.gearbox.ratios[1:], rtol=0.01)
    assert veh.gearbox.ratios[0] * 0.98 < got[0] < veh.gearbox.ratios[0] * 1.10
    b = idf.vehicle.body
    assert b.mass_kg == pytest.approx(veh.body.mass_kg, rel=0.01)  # 0.7 % high on this car
    assert b.road_load_a_n == pytest.approx(veh.body.road_load_a_n, abs=5.0)
    assert b.road_load_b_n_per_mps == pytest.approx(veh.body.road_load_b_n_per_mps, rel=0.03)
    c = idf.vehicle.engine_control
    assert c.idle_fuel_rate_g_per_s == pytest.approx(0.22, rel=0.03)
    assert idf.vehicle.engine.max_power_w == pytest.approx(veh.engine.max_power_w)
    np.testing.assert_allclose(idf.vehicle.converter.lockup_speed_mps[1:],
                               veh.converter.lockup_speed_mps[1:], atol=1.0)
    assert "option" in idf.vehicle.engine.sources["max_power_w"]
    # its own test predicted within 8 %, marked in sample, with an interval
    p = predict_trace(idf.vehicle, traces[0])
    assert p["in_sample"] and abs(p["error_rel"]) < 0.08  # -6.2 % measured
    assert 0.0 < p["pi95_rel"] < 0.3 and p["pi95_g"][0] < p["fuel_predicted_g"] < p["pi95_g"][1]
    assert 0.0 <= p["uncovered_share"] < 0.2


def test_without_a_spec_the_output_names_every_generic_value(car, tmp_path, capsys):
    _, files, tpl, _ = car
    out = tmp_path / "veh.yaml"
    rc = main(["identify", files["udds"], files["wltc3b"], "-t", tpl, "-o", str(out)])
    text = capsys.readouterr().out
    assert rc == 0
    named = [ln.split()[2] for ln in text.splitlines() if ln.startswith("generic value:")]
    assert {"rated_power_kw", "wheel_radius_m", "engine_inertia_kg_m2", "motoring_torque_nm",
            "full_load", "gearbox_efficiency"} <= set(named)
    doc = load_vehicle(out)
    prov = doc.identification["assumptions"]
    assert all(prov[k]["origin"] == "generic" for k in named)
    assert doc.engine.sources["inertia_kg_m2"].startswith("generic:")


def test_cross_validation_table_json_and_intervals(car, tmp_path, capsys):
    _, files, tpl, _ = car
    out = tmp_path / "cv.json"
    rc = main(["identify", files["udds"], files["wltc3b"], files["hwfet"], "-t", tpl,
               "--cross-validate", "--gears", "5", "-o", str(out)])
    text = capsys.readouterr().out
    assert rc == 0 and "cross-validation (leave-one-out)" in text
    doc = json.loads(out.read_text())
    assert doc["mode"] == "leave-one-out" and len(doc["rows"]) == 3
    for r in doc["rows"]:
        assert r["test"] not in r["identified_from"] and r["n_gears"] == 5
        assert r["pi95_rel"] > 0 and abs(r["error_rel"]) < 0.15
    s = doc["summary"]
    assert s["n_predictions"] == 3 and s["median_abs_error"] is not None


@pytest.mark.parametrize("args, words", [
    (["--cross-validate"], "needs at least two"),
    (["--gears", "3"], "3 gears declared, but the data show"),
])
def test_bad_input_one_line(car, tmp_path, capsys, args, words):
    _, files, tpl, _ = car
    argv = ["identify", files["udds"], "-t", tpl, "-o", str(tmp_path / "v.yaml"), *args]
    if "--gears" in args:
        argv.insert(2, files["wltc3b"])
    rc = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and words in err[0], err
    assert not (tmp_path / "v.yaml").exists()


def test_pairs_need_three_tests_and_a_spec_of_another_car_is_refused(car, tmp_path, capsys):
    _, files, tpl, _ = car
    rc = main(["identify", files["udds"], files["wltc3b"], "-t", tpl, "--cross-validate",
               "--pairs"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "at least three" in err[0]
    spec = tmp_path / "spec.yaml"
    spec.write_text("test_mass_kg: 2400\n")
    rc = main(["identify", files["udds"], files["wltc3b"], "-t", tpl, "--spec", str(spec),
               "-o", str(tmp_path / "v.yaml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "declared test mass 2400 kg" in err[0]


def test_predict_refuses_a_vehicle_of_another_car(car, capsys):
    _, files, tpl, _ = car
    rc = main(["predict", "cruze_diesel_2014", files["hwfet"], "-t", tpl])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "is not the tested car" in err[0]
