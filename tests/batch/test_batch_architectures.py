"""``vehval batch --steps validate`` validates every architecture the stage registry can
validate: a conventional car (the fuel prediction per phase) and a battery-electric car
(traces, DC energy and SAE J1634 figures), each on its own virtual test."""

from __future__ import annotations

import json

import yaml

from vehval.batch import run_batch
from vehval.cycles import load_cycle
from vehval.vehicle import load_vehicle


def _batch(tmp_path, vfile, make, folder="v1", tid="v1"):
    inp, out = tmp_path / "in", tmp_path / "out"
    truth = make(load_vehicle(vfile), load_cycle("udds"), 3, inp / folder)
    s = run_batch(inp, truth["template"], out, vehicle=str(vfile), steps=["qa", "validate"],
                  workers=0, report=True, progress=False)
    res = json.loads((out / "tests" / tid / "result.json").read_text())
    assert (s.n_ok, s.n_failed) == (1, 0), res.get("error")
    doc = json.loads((out / "tests" / tid / "validation.json").read_text())
    assert (out / "tests" / tid / "report.html").is_file()
    return doc, res


def test_batch_validates_a_conventional_car(tmp_path):
    from vehval.synth.conventional import make_conventional_test
    from vehval.vehicle.definition import _vehicles_dir

    doc, res = _batch(tmp_path, _vehicles_dir() / "cruze_diesel_2014.yaml",
                      make_conventional_test)
    # the fuel prediction of the test: measured and predicted fuel per phase
    assert doc["fuel_predicted_g"] > 0 and doc["fuel_measured_g"] > 0
    assert abs(doc["error_rel"]) < 0.1
    assert res["validation"]["error_rel"] == doc["error_rel"]
    # the En vehval predict states, per test and phase, and the catalog's normalised error
    assert doc["en"] is not None and all(p["en"] is not None for p in doc["phases"])
    ne = doc["normalised_error"]
    assert ne["en"] == doc["en"] and ne["measured_kg"] == doc["fuel_measured_g"] / 1e3
    assert ne["in_sample"] is False and doc["in_sample"] is False   # v1: not a source test
    assert res["validation"]["normalised_error"]["en"] == doc["en"]


def test_batch_marks_a_source_test_named_with_spaces_in_sample(tmp_path):
    """The vehicle file names its identification test ``61410013 Test Data``; the batch's id
    of the folder is ``61410013_Test_Data``: the same test, in-sample, with the En that
    ``vehval predict`` gives the same file; the catalog has En and the in-sample flag."""
    import duckdb

    from vehval.identify.loading import load_traces
    from vehval.identify.predict import predict_trace
    from vehval.identify.verdicts import judge_rows
    from vehval.synth.conventional import make_conventional_test
    from vehval.vehicle.definition import _vehicles_dir

    vfile = _vehicles_dir() / "cruze_diesel_2014.yaml"
    veh = load_vehicle(vfile)
    assert "61410013 Test Data" in veh.identification["tests"]
    doc, res = _batch(tmp_path, vfile, make_conventional_test,
                      folder="61410013 Test Data", tid="61410013_Test_Data")
    assert doc["test"] == "61410013_Test_Data"
    assert doc["in_sample"] is True and all(p["in_sample"] for p in doc["phases"])
    assert doc["en"] is not None and doc["consistent"] is not None
    assert doc["normalised_error"]["in_sample"] is True
    # vehval predict on the same file: the same En
    src = next((tmp_path / "in" / "61410013 Test Data").glob("*_d3.txt"))
    tpl = tmp_path / "in" / "61410013 Test Data" / "template.yaml"
    row = predict_trace(veh, load_traces([src], tpl)[0])
    judge_rows([row])
    assert abs(row["en"] - doc["en"]) < 1e-9
    con = duckdb.connect(str(tmp_path / "out" / "catalog.duckdb"), read_only=True)
    try:
        fuel_en, in_sample = con.execute(
            "SELECT fuel_en, in_sample FROM tests WHERE test_id = '61410013_Test_Data'").fetchone()
    finally:
        con.close()
    assert fuel_en == doc["en"] and in_sample is True


def test_batch_validates_a_battery_electric_car(tmp_path):
    from helpers.bev import bev_data
    from vehval.synth.bev import make_bev_test

    vfile = tmp_path / "test_bev.yaml"
    vfile.write_text(yaml.safe_dump(bev_data(), sort_keys=False), encoding="utf-8")
    doc, res = _batch(tmp_path, vfile, make_bev_test)
    assert doc["architecture"] == "battery_electric"
    assert [r["scope"] for r in doc["energy"]] == ["bag1", "bag2", "test"]
    assert all(abs(r["en"]) < 1.0 for r in doc["energy"])
    assert res["validation"]["architecture"] == "battery_electric"

