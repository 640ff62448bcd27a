"""The README flow `vehval results` then `vehval report` on the same folder."""

import json

from .test_cli_realdata import _files


def test_results_then_report_on_the_same_folder(tmp_path, cli):
    raw, tpl = _files(tmp_path)
    out = tmp_path / "out"
    code, stdout, err = cli("results", raw, "-t", tpl, "-o", out, "--json")
    assert code == 0, err
    assert json.loads(stdout)["files"] == ["results.json", "findings.json", "validated.parquet"]
    code, stdout, err = cli("report", out, "--no-excel")
    assert code == 0, err
    html = (out / "report.html").read_text()
    assert "Test results" in html and "Regulatory composites" in html
