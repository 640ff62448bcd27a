"""The workflow's validate step on a conventional car: the fuel prediction per phase (the
comparison of ``vehval predict``), not a refusal; the ranking of ``vehval validate`` still
refuses it in one line."""

from __future__ import annotations

import json

import pytest

from vehval.cli import main


@pytest.fixture(scope="module")
def virtual(tmp_path_factory):
    out = tmp_path_factory.mktemp("conv") / "v"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "ece15", "--seed", "3",
                 "-o", str(out)]) == 0
    return next(out.glob("*_d3.txt")), out / "template.yaml"


def test_validate_step_runs_the_prediction(virtual, capsys):
    from vehval.errors import ConfigError
    from vehval.workflow import TestRun

    f, tpl = virtual
    run = TestRun.load([f], tpl, "cruze_diesel_2014", use_qa=False)
    outcome = run.validate()
    doc = outcome.document
    assert doc["fuel_measured_g"] > 0 and doc["fuel_predicted_g"] > 0
    assert abs(doc["error_rel"]) < 0.2 and doc["phases"]
    assert "sim" not in doc and "trace" not in doc          # the public row, no arrays
    # the same row as `vehval predict --json`
    capsys.readouterr()
    assert main(["predict", "cruze_diesel_2014", str(f), "-t", str(tpl), "--json"]) == 0
    row = json.loads(capsys.readouterr().out)[0]
    assert row["fuel_predicted_g"] == pytest.approx(doc["fuel_predicted_g"])
    assert row["fuel_measured_g"] == pytest.approx(doc["fuel_measured_g"])
    pay = outcome.payload(figures=False)
    assert pay["tables"][0]["rows"][-1][0] == "whole test" and pay["notes"]
    with pytest.raises(ConfigError, match="fuel prediction per phase"):
        outcome.validation   # noqa: B018 - no simulation on the test's conditions to overlay
