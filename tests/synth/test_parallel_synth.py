"""Virtual parallel-hybrid tests: synth writes the answer key, analyze and validate find it."""

from __future__ import annotations

import json

import pytest

from helpers.cli import run_cli
from vehval.analysis.parallel import analyze_parallel
from vehval.cycles import load_cycle
from vehval.io.importer import import_test
from vehval.synth.parallel import make_parallel_test
from vehval.validate.parallel import parallel_figures, simulate_on_test
from vehval.vehicle import load_vehicle


@pytest.fixture(scope="module")
def virtual(tmp_path_factory):
    veh = load_vehicle("insight_2000").with_overrides(
        {"controller.assist_threshold_nm": 40.0, "controller.engine_stop_speed_mps": 5.0})
    out = tmp_path_factory.mktemp("par") / "v"
    truth = make_parallel_test(veh, load_cycle("udds"), 11, out, vehicle_ref="insight_2000")
    return veh, truth, import_test(truth["files"], truth["template"])


def test_analysis_recovers_the_known_rules(virtual):
    veh, truth, test = virtual
    r = analyze_parallel(test, veh)
    ar = r["assist_regen"]
    assert ar["assist_threshold"]["threshold"] == pytest.approx(40.0, abs=2.0)
    assert ar["assist_threshold"]["support"] > 0.95
    assert ar["assist_share_by_gear"][1] == 0.0
    # no regen below the known speed (here the engine stops first, at 5 m/s)
    assert truth["rules"]["regen_min_speed_mps"] - 0.1 <= ar["regen_min_speed_mps"] < 5.3
    stop = r["engine_stop"]["rule"]
    assert stop["support"] == 1.0 and stop["threshold"] == pytest.approx(5.0, abs=0.3)


def test_validation_of_the_generating_model_agrees(virtual):
    veh, truth, test = virtual
    sim = simulate_on_test(veh, test, soc0=veh.controller.soc_target)
    f = parallel_figures(veh, sim)["all"]
    assert f["engine_on_agreement_pct"] > 99.0
    assert f["battery_out_model_wh"] == pytest.approx(f["battery_out_test_wh"], rel=0.05)
    assert f["battery_in_model_wh"] == pytest.approx(f["battery_in_test_wh"], rel=0.05)
    assert f["motor_torque_rms_nm"] < 4.0  # assist steps of 6 N·m toggle a step apart
    assert f["engine_speed_rms_rpm"] < 60.0 and f["gear_agreement_pct"] > 90.0


def test_validation_sees_a_wrong_model(virtual):
    veh, truth, test = virtual
    wrong = veh.with_overrides({"controller.assist_threshold_nm": 20.0})
    f = parallel_figures(wrong, simulate_on_test(wrong, test, soc0=0.69))["all"]
    assert f["battery_out_model_wh"] > 1.3 * f["battery_out_test_wh"]


def test_synth_and_analyze_cli(tmp_path, capsys):
    out = tmp_path / "syn"
    rc, so, se = run_cli(["synth", "--vehicle", "insight_2000", "--cycle", "udds", "-o", out,
                          "--control", "assist_threshold_nm=35"], capsys)
    assert rc == 0, se
    truth = json.loads((out / "truth.json").read_text())
    assert truth["rules"]["assist_threshold_nm"] == 35.0
    data = sorted(out.glob("*_10hz.txt"))
    rc, so, se = run_cli(["analyze", *data, "-t", out / "template.yaml", "-o", tmp_path / "an",
                          "--no-qa"], capsys)
    assert rc == 0, se
    ctl = json.loads((tmp_path / "an" / "control.json").read_text())
    assert ctl["architecture"] == "parallel_hybrid"
    assert ctl["assist_regen"]["assist_threshold"]["threshold"] == pytest.approx(35.0, abs=2.0)
    assert "assist when shaft torque demand" in so


def test_qa_uses_the_parallel_hybrid_equations(virtual, tmp_path, capsys):
    veh, truth, test = virtual
    rc, so, se = run_cli(["qa", *truth["files"], "-t", truth["template"], "-o", tmp_path / "qa"],
                         capsys)
    assert rc == 0, se
    f = json.loads((tmp_path / "qa" / "findings.json").read_text())
    assert f["calculations"]["set"] == "parallel_hybrid"
    assert "mot_spd_out_calc" in f["calculations"]["computed"]
    check = next(c for c in f["checks"] if c["check"] == "electrical power balance")
    assert check["r2"] > 0.8 and check["slope"] > 0  # the current's sign is right


def test_the_flow_validates_and_analyzes_a_parallel_hybrid_through_the_registry(virtual):
    from vehval.architectures import stages
    from vehval.workflow import TestRun

    veh, truth, _ = virtual
    assert stages(veh).family == "hybrid"
    run = TestRun.load(truth["files"], truth["template"], veh)
    outcome = run.validate()
    doc = outcome.document
    assert doc["architecture"] == "parallel_hybrid" and doc["soc_initial"] == 0.69
    f = doc["figures"]["all"]
    assert f["engine_on_agreement_pct"] > 98.0
    assert f["battery_out_model_wh"] == pytest.approx(f["battery_out_test_wh"], rel=0.1)
    pay = outcome.payload(figures=True)
    assert pay["tables"][0]["rows"] and pay["figures"]
    assert any("no measured SOC" in n for n in pay["notes"])
    ana = run.analyze().result.to_dict()
    assert ana["architecture"] == "parallel_hybrid" and isinstance(ana["findings"], list)


def test_a_stated_parallel_hybrid_gets_its_relation_set_without_a_vehicle(virtual):
    from vehval.equations.calc import choose_calc_set

    _, _, test = virtual
    assert choose_calc_set(test, None, "parallel_hybrid") == "parallel_hybrid"
    assert choose_calc_set(test, None, "battery_electric") == "conventional"


def test_the_strategy_read_from_a_log_states_its_rules(virtual, tmp_path):
    veh, truth, test = virtual
    s = analyze_parallel(test, veh)["strategy"]
    assert s["assist_threshold_nm"] == pytest.approx(40.0, abs=2.0)
    assert s["assist_min_gear"] == 2 and s["engine_stop_speed_mps"] == pytest.approx(5.0, abs=0.3)
    assert s["regen_threshold_nm"] <= 0.0 and s["motor_off_when_idle"] is True
    # a car whose inverter is off at idle: the idle draw read is its accessory load
    quiet = veh.with_overrides({"controller.motor_off_when_idle": True,
                                "controller.electrical_aux_power_w": 150.0})
    t2 = make_parallel_test(quiet, load_cycle("hwfet"), 3, tmp_path / "q",
                            vehicle_ref="insight_2000")
    r2 = analyze_parallel(import_test(t2["files"], t2["template"]), quiet)
    assert r2["idle_battery_power"]["median_w"] == pytest.approx(150.0, abs=15.0)
    assert r2["strategy"]["electrical_aux_power_w"] == pytest.approx(150.0, abs=15.0)
    # applied to the model, the read strategy is a valid vehicle
    veh.with_overrides({f"controller.{k}": v for k, v in r2["strategy"].items()})


def test_validate_command_judges_a_parallel_hybrid_by_its_battery_energy(virtual, tmp_path,
                                                                       capsys):
    """`vehval validate` of a parallel hybrid (it refused one): the generating model is
    consistent on the net battery energy (U_model from one-at-a-time swings, U_test from
    the sensor class defaults), a model with a wrong assist threshold is not."""
    import yaml

    veh, truth, _ = virtual
    good = tmp_path / "good.yaml"
    raw = yaml.safe_load(open(veh.file, encoding="utf-8"))
    raw["controller"].update(assist_threshold_nm=40.0, engine_stop_speed_mps=5.0)
    good.write_text(yaml.safe_dump(raw, sort_keys=False), encoding="utf-8")
    raw["controller"]["assist_threshold_nm"] = 10.0
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(raw, sort_keys=False), encoding="utf-8")
    files = [str(f) for f in truth["files"]]
    words = {}
    for name, vfile in (("good", good), ("bad", bad)):
        rc, so, se = run_cli(["validate", *files, "-t", truth["template"], "--vehicle", vfile,
                              "-o", tmp_path / name], capsys)
        assert rc == 0, se
        doc = json.loads((tmp_path / name / "metrics.json").read_text())
        v = doc["tests"][0]["verdict"]
        assert v["figure"] == "battery_energy_wh" and f"En {v['en']:+.2f}" in so
        assert doc["tests"][0]["verdicts"]["all"]["battery_energy"]["u_model_wh"] > 0
        words[name] = v["consistent"]
    assert words == {"good": True, "bad": False}
