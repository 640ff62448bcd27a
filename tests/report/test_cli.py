"""`vehval report QA_OUTDIR`: reads findings.json + validated.parquet, writes report + tables."""

from __future__ import annotations

import json

import pytest

from vehval.cli import main

from .conftest import make_qa, make_test

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
