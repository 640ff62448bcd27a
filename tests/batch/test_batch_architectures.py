"""``vehval batch --steps validate`` validates every architecture the stage registry can
validate: a conventional car (the fuel prediction per phase) and a battery-electric car
(traces, DC energy and SAE J1634 figures), each on its own virtual test."""

from __future__ import annotations

import json

import yaml

from vehval.batch import run_batch
from vehval.cycles import load_cycle
from vehval.vehicle import load_vehicle


def _batch(tmp_path, vfile, make):
    inp, out = tmp_path / "in", tmp_path / "out"
    truth = make(load_vehicle(vfile), load_cycle("udds"), 3, inp / "v1")
    s = run_batch(inp, truth["template"], out, vehicle=str(vfile), steps=["qa", "validate"],
                  workers=0, report=True, progress=False)
    res = json.loads((out / "tests" / "v1" / "result.json").read_text())
    assert (s.n_ok, s.n_failed) == (1, 0), res.get("error")
    doc = json.loads((out / "tests" / "v1" / "validation.json").read_text())
    assert (out / "tests" / "v1" / "report.html").is_file()
    return doc, res


def test_batch_validates_a_conventional_car(tmp_path):
    from vehval.synth.conventional import make_conventional_test
    from vehval.vehicle.definition import _vehicles_dir

    doc, res = _batch(tmp_path, _vehicles_dir() / "cruze_diesel_2014.yaml",
                      make_conventional_test)
    # the fuel prediction of the test: measured and predicted fuel per phase
    assert doc["fuel_predicted_g"] > 0 and doc["fuel_measured_g"] > 0
    assert abs(doc["error_rel"]) < 0.1
    assert "normalised_error" not in doc and res["validation"]["error_rel"] == doc["error_rel"]


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

