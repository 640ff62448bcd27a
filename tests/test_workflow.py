"""The workflow core: one TestRun behind every command and the batch runner."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from vehval.cli import main
from vehval.workflow import AnalysisOutcome, QAOutcome, TestRun, ValidationOutcome, group_args, runs_from_args


@pytest.fixture(scope="module")
def virtual(tmp_path_factory):
    from vehval.synth import make_virtual_test

    d = tmp_path_factory.mktemp("wf") / "ece"
    make_virtual_test("prius_2004", "ece15", seed=5, faults="none", outdir=d)
    return d


def _files(d: Path) -> list[Path]:
    return sorted(d.glob("*_d3.txt")) + sorted(d.glob("*_obd.csv"))


def test_steps_return_typed_outcomes_and_run_once(virtual):
    run = TestRun.load(_files(virtual), virtual / "template.yaml", "prius_2004")
    qa = run.qa()
    assert isinstance(qa, QAOutcome) and run.qa() is qa          # once per run
    assert qa.document["findings_version"] == 1 and run.validated is qa.validated
    an = run.analyze()
    assert isinstance(an, AnalysisOutcome) and "controller" in an.document
    val = run.validate(dt=0.5)
    assert isinstance(val, ValidationOutcome)
    assert val.document["vehicle"] == "prius_2004" and val.payload(figures=False)["tables"]


def test_directory_and_files_give_the_same_run(virtual):
    by_dir = TestRun.from_paths([virtual])
    by_files = TestRun.from_paths(_files(virtual), virtual / "template.yaml")
    assert sorted(s.name for s in by_dir.test) == sorted(s.name for s in by_files.test)
    assert group_args([virtual], ["a.txt,b.csv"]) == [[virtual], [Path("a.txt"), Path("b.csv")]]
    runs = runs_from_args([virtual], [str(virtual)])
    assert [r.test.meta.test_id for r in runs] == ["ece", "ece_2"]   # ids made unique


def test_one_time_policy_in_every_command(virtual, tmp_path):
    """A repeated time stamp: repaired with a note in qa, analyze and validate alike (before,
    only validate repaired it and qa/analyze/batch stopped)."""
    d = tmp_path / "rep"
    d.mkdir()
    for f in virtual.iterdir():
        (d / f.name).write_bytes(f.read_bytes())
    d3 = next(d.glob("*_d3.txt"))
    lines = d3.read_text().splitlines(keepends=True)
    lines.insert(60, lines[59])                       # one sample twice
    d3.write_text("".join(lines))
    files = [str(p) for p in _files(d)]
    tpl = str(d / "template.yaml")
    assert main(["qa", *files, "-t", tpl, "-o", str(tmp_path / "qa"), "--json"]) == 0
    assert main(["analyze", *files, "-t", tpl, "-o", str(tmp_path / "an")]) == 0
    assert main(["validate", str(d), "--vehicle", "prius_2004", "--dt", "1",
                 "-o", str(tmp_path / "val")]) == 0
    assert json.loads((tmp_path / "qa" / "findings.json").read_text())["summary"]["kept"] > 0
    run = TestRun.load(files, tpl)
    assert any("1 repeated timestamp(s) dropped" in n for n in run.test.meta.notes)


def test_validation_needs_a_vehicle(virtual):
    from vehval.errors import ConfigError

    run = TestRun.from_paths([virtual])
    run.vehicle = None
    with pytest.raises(ConfigError, match="needs a vehicle"):
        run.validate()


def test_loaded_objects_satisfy_the_protocols(virtual):
    from vehval.protocols import TemplateLike, VehicleLike

    run = TestRun.from_paths([virtual], vehicle="prius_2004")
    assert isinstance(run.template, TemplateLike) and isinstance(run.vehicle, VehicleLike)


def test_a_validated_test_is_gated_by_the_findings_beside_it(virtual, tmp_path):
    """`vehval validate OUTDIR` of a `vehval qa` output reads validated.parquet: the fuel
    figure QA withheld there stays withheld (it was stated, ungated, and its mpg computed
    with the vehicle's fuel instead of the template's); findings of another test are
    refused."""
    from vehval.errors import InputFileError
    from vehval.io.parquet import write_test

    run = TestRun.load(_files(virtual), virtual / "template.yaml", "prius_2004")
    out = tmp_path / "qa"
    out.mkdir()
    write_test(run.qa().validated, out / "validated.parquet")
    doc = dict(run.qa().document)
    clean = TestRun.from_paths([out], vehicle="prius_2004").results().results
    assert not clean.withheld and clean.value("test", "fuel_economy_mpg") > 0
    error = {"signal": "fuel_rate_test", "kind": "range", "severity": "error", "level": 1,
             "start_s": 10.0, "end_s": 12.0, "message": "fuel_rate_test reaches -5 g/s"}
    doc["findings"] = [*doc.get("findings", []), error]
    (out / "findings.json").write_text(json.dumps(doc))
    for given in (out, out / "validated.parquet"):
        held = TestRun.from_paths([given], vehicle="prius_2004").results().results
        assert "fuel_economy_mpg" in held.withheld["test"]["quantities"]
    doc["findings"][-1] = {"signal": "fuel_rate_test"}
    (out / "findings.json").write_text(json.dumps(doc))
    with pytest.raises(InputFileError, match="finding .* is damaged"):
        TestRun.from_paths([out], vehicle="prius_2004")
    doc["test"] = {**doc["test"], "id": "another"}
    (out / "findings.json").write_text(json.dumps(doc))
    with pytest.raises(InputFileError, match="is of test 'another'"):
        TestRun.from_paths([out], vehicle="prius_2004")
