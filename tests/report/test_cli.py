"""`vehval report QA_OUTDIR`: reads findings.json + validated.parquet, writes report + tables."""

from __future__ import annotations

import json

import pytest

from vehval.cli import main

from .helpers import make_control, make_qa, make_test

parquet = pytest.importorskip("vehval.io.parquet")


@pytest.fixture
def qa_outdir(tmp_path):
    out = tmp_path / "qa_out"
    out.mkdir()
    parquet.write_test(make_test(), out / "validated.parquet")
    (out / "findings.json").write_text(json.dumps(make_qa()), encoding="utf-8")
    (out / "validation.json").write_text(json.dumps({"tables": [{"title": "Fuel", "columns": ["a", "b"],
                                                                 "rows": [[1, 2]]}]}), encoding="utf-8")
    return out


def test_report_from_qa_outdir(qa_outdir, capsys):
    assert main(["report", str(qa_outdir)]) == 0
    html = (qa_outdir / "report.html").read_text(encoding="utf-8")
    assert 'data-table="table2"' in html and '<section id="validation"' in html
    assert (qa_outdir / "tables.xlsx").stat().st_size > 0
    assert "wrote" in capsys.readouterr().out


def test_report_to_other_file_without_excel(qa_outdir, tmp_path):
    out = tmp_path / "elsewhere" / "r.html"
    assert main(["report", str(qa_outdir / "findings.json"), str(qa_outdir / "validated.parquet"),
                 "-o", str(out), "--no-excel", "--title", "My test"]) == 0
    assert "<title>My test</title>" in out.read_text(encoding="utf-8")
    assert not (out.parent / "tables.xlsx").exists()


def test_user_errors_are_one_line(tmp_path, capsys):
    assert main(["report", str(tmp_path / "nope")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vehval: error:") and "not found" in err and "Traceback" not in err
    (tmp_path / "findings.json").write_text("{bad", encoding="utf-8")
    assert main(["report", str(tmp_path)]) == 2
    assert "validated" in capsys.readouterr().err
    parquet.write_test(make_test(), tmp_path / "validated.parquet")
    assert main(["report", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "findings.json" in err and "line 1" in err


def _sections(html: str) -> list[str]:
    import re

    return re.findall(r'<section id="([^"]+)"', html)


def test_validate_report_then_combined_report(qa_outdir, tmp_path, capsys):
    """qa dir (+ control.json of analyze) -> `vehval validate --report` -> `vehval report`."""
    (qa_outdir / "validation.json").unlink()
    (qa_outdir / "control.json").write_text(json.dumps(make_control()), encoding="utf-8")
    val = tmp_path / "val"
    assert main(["validate", str(qa_outdir), "-o", str(val), "--report"]) == 0
    html = (val / "report.html").read_text(encoding="utf-8")
    # the validation report found findings.json and control.json beside validated.parquet
    assert _sections(html)[-2:] == ["control", "validation"]
    assert 'data-table="table2"' in html and 'data-table="control-operating-modes"' in html
    assert list(val.glob("overlays_*.parquet"))
    # the validate output directory is an input too: its overlays Parquet is not the test
    assert main(["report", str(qa_outdir), str(val), "-o", str(tmp_path / "all" / "report.html")]) == 0
    out = capsys.readouterr().out
    assert f"validation {val / 'validation.json'}" in out and "overlays" not in out
    html = (tmp_path / "all" / "report.html").read_text(encoding="utf-8")
    assert _sections(html)[-2:] == ["control", "validation"]


def test_explicit_control_validation_and_raw(qa_outdir, tmp_path):
    ctl = tmp_path / "elsewhere" / "ctl.json"
    ctl.parent.mkdir()
    ctl.write_text(json.dumps(make_control()), encoding="utf-8")
    raw = tmp_path / "imported.parquet"
    parquet.write_test(make_test(), raw)
    out = tmp_path / "r" / "report.html"
    assert main(["report", str(qa_outdir), "--control", str(ctl), "--validation",
                 str(qa_outdir / "validation.json"), "--raw", str(raw), "-o", str(out), "--no-excel"]) == 0
    html = out.read_text(encoding="utf-8")
    assert _sections(html)[-2:] == ["control", "validation"]
    assert main(["report", str(qa_outdir), "--control", str(tmp_path / "missing.json")]) == 2


@pytest.mark.parametrize("name", ["validated.parquet", "findings.json", "validation.json"])
def test_an_output_over_a_file_of_the_input_directory_is_refused(qa_outdir, capsys, name):
    """The directory given is an input, and so is every file the report reads from it."""
    target = qa_outdir / name
    before = target.read_bytes()
    assert main(["report", str(qa_outdir), "-o", str(target)]) == 2
    err = capsys.readouterr().err
    assert "also an input" in err and name in err
    assert target.read_bytes() == before and not (qa_outdir / "tables.xlsx").exists()


def test_a_document_of_another_kind_or_test_is_refused(qa_outdir, tmp_path, capsys):
    res = tmp_path / "results.json"
    res.write_text(json.dumps({"results_version": 3, "test": {"id": "T-report"}}),
                   encoding="utf-8")
    out = tmp_path / "r.html"
    assert main(["report", str(qa_outdir), "--validation", str(res), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "is a results document ('results_version'), not a validation document" in err
    # findings of another test beside this test's Parquet
    other = tmp_path / "other"
    other.mkdir()
    (other / "findings.json").write_text(json.dumps(make_qa() | {"test": {"id": "T-other"}}),
                                         encoding="utf-8")
    assert main(["report", str(qa_outdir), str(other), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "is of test 'T-other'" in err and "'T-report'" in err
    # two tests, and a raw test of another id
    parquet.write_test(make_test(), other / "validated.parquet")
    assert main(["report", str(qa_outdir), str(other), "-o", str(out)]) == 2
    assert "two tests given" in capsys.readouterr().err
    raw_test = make_test()
    raw_test.meta.test_id = "T-other"
    parquet.write_test(raw_test, tmp_path / "raw.parquet")
    assert main(["report", str(qa_outdir), "--raw", str(tmp_path / "raw.parquet"),
                 "-o", str(out)]) == 2
    assert "raw.parquet: is of test 'T-other'" in capsys.readouterr().err
    assert not out.exists() and not (tmp_path / "tables.xlsx").exists()
