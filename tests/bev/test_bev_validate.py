"""A battery-electric test validated: the model against the test's traces, DC energy and
SAE J1634 figures, through import, QA, results, validate and the report."""

from __future__ import annotations

import json

import pytest

from vehval.cycles import load_cycle
from vehval.errors import ConfigError
from vehval.vehicle import load_vehicle


@pytest.fixture(scope="module")
def virtual(tmp_path_factory):
    """A virtual UDDS test of the test BEV and its vehicle file."""
    import yaml

    from helpers.bev import bev_data
    from vehval.synth.bev import make_bev_test

    root = tmp_path_factory.mktemp("bev_validate")
    vfile = root / "test_bev.yaml"
    vfile.write_text(yaml.safe_dump(bev_data(), sort_keys=False), encoding="utf-8")
    truth = make_bev_test(load_vehicle(vfile), load_cycle("udds"), 5, root / "virt")
    return truth, vfile, root


def _run(virtual, vehicle=None):
    from vehval.workflow import TestRun

    truth, vfile, _ = virtual
    return TestRun.load(truth["files"], truth["template"], vehicle or vfile)


def test_virtual_bev_through_import_qa_results_validate_report(virtual):
    """The generating model validates within its noise: traces, energy per phase, J1634."""
    run = _run(virtual)
    assert not [f for f in run.qa().result.findings if f.severity.name == "ERROR"]
    out = run.validate()
    doc = json.loads(json.dumps(out.document))
    assert doc["architecture"] == "battery_electric"
    assert doc["traces"]["veh_spd"]["rmse"] < 0.2          # m/s
    assert doc["traces"]["ess_curr"]["rmse"] < 2.0         # A (0.2 A noise, driver lag)
    assert doc["traces"]["ess_volt"]["rmse"] < 1.0         # V
    scopes = [r["scope"] for r in doc["energy"]]
    assert scopes == ["bag1", "bag2", "test"]
    for r in doc["energy"]:
        assert abs(r["error_pct"]) < 1.5 and abs(r["en"]) < 1.0, r
        assert r["U_meas"] > 0 and r["U_model"] > 0
    key = virtual[0]["j1634"]["test"]
    mpge = next(r for r in doc["j1634"] if r["scope"] == "test" and r["figure"] == "mpge")
    assert mpge["test"] == pytest.approx(key["mpge"], rel=0.005)
    assert mpge["model"] == pytest.approx(key["mpge"], rel=0.015)
    assert any("U_model" in n and "declared bound" in n for n in doc["notes"])
    payload = out.payload()
    assert [t["title"].split(",")[0] for t in payload["tables"]] == [
        "Traces", "DC battery energy", "SAE J1634 figures"]
    assert payload["figures"]                               # overlays of speed and battery
    paths = run.report(virtual[2] / "report", excel=False).paths
    html = paths["report"].read_text(encoding="utf-8")
    assert "SAE J1634 figures, model vs test" in html
    # the energy flow in J1634 terms, no engine or fuel plots
    assert "SAE J1634 energy per phase" in html and "regenerative share" in html
    assert "Engine map" not in html and "Willans" not in html


def test_validation_sees_a_wrong_model(virtual):
    """A model with twice the accessory load is inconsistent on the DC energy: the check
    can fail."""
    run = _run(virtual)
    doc = run.validate(overrides={"body.aux_power_w": 3000.0}).document
    test_row = next(r for r in doc["energy"] if r["scope"] == "test")
    assert test_row["error_pct"] > 20.0
    assert doc["overrides"]["body.aux_power_w"] == 3000.0


def test_suite_validate_refuses_a_bev_in_one_line(virtual):
    from vehval.validate.ladder import Tolerances
    from vehval.workflow import validate_runs

    with pytest.raises(ConfigError) as exc:
        validate_runs([_run(virtual)], Tolerances.from_mapping({}))
    msg = str(exc.value)
    assert "\n" not in msg and "battery_electric" in msg and "vehval results" in msg


def test_results_take_the_charger_of_the_vehicle_given(virtual):
    """`--vehicle` (the run's vehicle) gives the charger efficiency of the J1634 figures;
    the template alone names none (assumed 0.88)."""
    import yaml

    from helpers.bev import bev_data
    from vehval.workflow import TestRun

    truth, _, root = virtual
    data = bev_data()
    data["charger"]["efficiency"] = 0.8
    vfile = root / "charger_080.yaml"
    vfile.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    alone = TestRun.load(truth["files"], truth["template"]).results().results.j1634
    given = _run(virtual, vfile).results().results.j1634
    assert alone["charger_efficiency_assumed"] and alone["charger_efficiency"] == 0.88
    assert given["charger_efficiency"] == 0.8 and not given["charger_efficiency_assumed"]
    dc = given["scopes"]["test"]["dc_energy_kwh"]
    assert given["scopes"]["test"]["ac_energy_kwh"] == pytest.approx(dc / 0.8)


def test_measured_wall_energy_constant_feeds_the_test_scope(virtual, tmp_path):
    from vehval.workflow import TestRun

    truth = virtual[0]
    text = open(truth["template"], encoding="utf-8").read().replace(
        "constants:\n", "constants:\n  ac_recharge_energy_j: 5.4e6\n")
    tpl = tmp_path / "template.yaml"
    tpl.write_text(text, encoding="utf-8")
    j = TestRun.load(truth["files"], tpl).results().results.j1634["scopes"]["test"]
    assert j["ac_basis"] == "measured wall energy"
    assert j["ac_energy_kwh"] == pytest.approx(1.5)


def test_qa_runs_no_engine_fuel_or_hybrid_relation_on_a_bev(virtual):
    """QA's calculations consult the architecture table: nothing engine or fuel is tried."""
    run = _run(virtual)
    calc = run.qa().result.calculations.to_dict()
    assert calc["architecture"] == "battery_electric" and calc["set"] == "conventional"
    tried = list(calc["computed"]) + list(calc["not_computed"])
    assert not [n for n in tried if n.startswith(("eng_", "fuel_"))], tried
    assert "eng_pwr_out_calc" in calc["not_applicable"]
    assert "ess_pwr_calc" in calc["computed"]          # the battery relations still run


def test_results_screen_states_j1634_energy_in_the_display_units(virtual, tmp_path, capsys,
                                                                 monkeypatch):
    """`vehval --units metric results` of a BEV: the SAE J1634 lines read kWh/100 km like
    its headline (they read kWh/100 mi whatever the units)."""
    from vehval.cli import main

    monkeypatch.setenv("VEHVAL_UNITS", "us")     # `--units` sets it: restored after the test
    truth = virtual[0]
    args = ["results", *map(str, truth["files"]), "-t", str(truth["template"])]
    assert main([*args, "-o", str(tmp_path / "a"), "--json"]) == 0
    test = json.loads(capsys.readouterr().out)["j1634"]["scopes"]["test"]
    for system, key, unit in (("us", "ac_kwh_per_100mi", "kWh/100 mi"),
                              ("metric", "ac_kwh_per_100km", "kWh/100 km")):
        assert main(["--units", system, *args, "-o", str(tmp_path / system)]) == 0
        line = next(x for x in capsys.readouterr().out.splitlines()
                    if x.strip().startswith("test ") and "DC" in x)
        assert f"AC {test[key]:.1f} {unit}  {test['mpge']:.1f} MPGe" in line


def test_validate_command_judges_a_bev_test_by_test(virtual, tmp_path, capsys):
    """`vehval validate` of a battery-electric car (it refused one, pointing to the Python
    API): each test judged by the En of its whole-test DC energy, written and reported."""
    from vehval.cli import main

    truth, vfile, _ = virtual
    out = tmp_path / "val"
    args = ["validate", *map(str, truth["files"]), "-t", str(truth["template"]),
            "--vehicle", str(vfile), "-o", str(out)]
    assert main([*args, "--report"]) == 0
    text = capsys.readouterr().out
    doc = json.loads((out / "metrics.json").read_text())
    v = doc["tests"][0]["verdict"]
    assert doc["architecture"] == "battery_electric" and v["figure"] == "dc_energy_wh"
    assert abs(v["en"]) < 1.0 and v["consistent"] is True and v["in_sample"] is False
    assert f"En {v['en']:+.2f} consistent" in text and "MPGe" in text
    assert "held-out: 1/1 consistent (|En| <= 1)" in text
    assert (out / "report.html").is_file() and (out / "validation.json").is_file()
    assert "SAE J1634 figures, model vs test" in (out / "report.html").read_text()
    # a wrong model is judged inconsistent: the verdict can fail
    import yaml

    from helpers.bev import bev_data

    data = bev_data()
    data["body"]["aux_power_w"] = 3000.0
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    assert main([*args[:-4], "--vehicle", str(wrong), "-o", str(tmp_path / "w")]) == 0
    assert "inconsistent" in capsys.readouterr().out


def test_validate_command_states_the_set_verdict_of_three_bev_tests(virtual, tmp_path,
                                                                    capsys):
    """Three held-out tests of one car judged test by test: the set verdict of their DC
    energies (bias with its interval and coverage), as the power-split ladder states it."""
    from vehval.cli import main
    from vehval.synth.bev import make_bev_test

    truth, vfile, _ = virtual
    args = []
    for seed in (6, 7):
        t = make_bev_test(load_vehicle(vfile), load_cycle("ece15"), seed, tmp_path / f"e{seed}")
        args += ["--test", ",".join(map(str, t["files"]))]
    args += ["--test", ",".join(map(str, truth["files"]))]
    assert main(["validate", *args, "-t", str(truth["template"]), "--vehicle", str(vfile),
                 "-o", str(tmp_path / "val")]) == 0
    out = capsys.readouterr().out
    doc = json.loads((tmp_path / "val" / "metrics.json").read_text())
    sv = doc["set_verdict"]
    assert sv["n"] == 3 and sv["n_consistent"] == 3
    assert "held-out: 3/3 consistent (|En| <= 1); set verdict (n = 3): " in out
