"""One rule for "is this test one the vehicle file was fitted on":
vehval.calibration.provenance.same_test.

A vehicle file names its tests as identification or calibration saw them (``61410013 Test
Data``, the file's stem); a batch names the same test by its id (``61410013_Test_Data``).
Every in-sample check (the calibration provenance, the validation ladder, the prediction of
an identified car) matches them with the one rule.
"""

import re
from pathlib import Path

from vehval.calibration.provenance import in_sample, same_test

SRC = Path(__file__).resolve().parents[1] / "src" / "vehval"


def test_a_name_with_spaces_is_its_batch_id():
    assert same_test("61410013_Test_Data", ["61410013 Test Data", "61410004 Test Data"])
    assert same_test("61410013 Test Data", ["61410013_Test_Data"])
    assert not same_test("61410013_Test_Data", ["61410004 Test Data"])
    assert not same_test("", [""]) and not same_test("test", [""])


def test_calibration_provenance_uses_the_rule():
    veh = {"engine": {"sources": {"x": "calibrated by vehval calibrate on tests Prius c #3 "
                                       "on 2026-01-02: RMS 1 -> 0.5 (powell)"}}}
    assert in_sample(veh, "Prius_c_3") and in_sample(veh, "Prius c #3")
    assert not in_sample(veh, "Prius_c_4")


def test_ladder_marks_a_calibration_test_by_its_batch_id(monkeypatch):
    import importlib
    from types import SimpleNamespace

    lad_mod = importlib.import_module("vehval.validate.ladder")

    monkeypatch.setattr(lad_mod, "verdict", lambda c, tol: (True, [], {}))
    monkeypatch.setattr(lad_mod, "judge_fuel", lambda *a, **k: None)
    comps = [SimpleNamespace(test_id=t, cycle="udds") for t in ("Prius_c_3", "Prius_c_4")]
    lad = lad_mod.ladder(comps, calibrated={"Prius c #3": ["engine.x"]})
    assert {e.test_id: e.in_sample for e in lad.entries} == {"Prius_c_3": True,
                                                              "Prius_c_4": False}


def test_no_plain_membership_of_the_fitted_tests():
    bad = []
    pat = re.compile(r"test_id\s+in\s+(_fitted_tests|\(?calibrated)")
    for path in SRC.rglob("*.py"):
        if pat.search(path.read_text(encoding="utf-8")):
            bad.append(str(path.relative_to(SRC)))
    assert not bad, f"test ids matched outside calibration.provenance.same_test: {bad}"
