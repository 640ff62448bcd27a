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


def test_channel_accuracy_offsets_in_display_units():
    """The offsets were shown as 'offset [SI]' 2.000e-06 (kg/s); a lab reads 0.002 g/s."""
    from vehval.report.results_view import results_section

    doc = {"uncertainty": {"accuracy": {
        "fuel_rate_test": {"reading_pct": 1.0, "offset_si": 2e-6, "basis": "class default"},
        "veh_spd_test": {"reading_pct": 0.1, "offset_si": 0.01, "basis": "class default"}}}}
    sec = results_section(doc)
    table = next(t for t in sec.tables if t.title == "Channel accuracies")
    assert "offset [SI]" not in table.columns
    offsets = {r[0]: r[2] for r in table.rows}
    assert offsets["fuel_rate_test"] == "0.002 g/s"
    assert offsets["veh_spd_test"] in ("0.02237 mph", "0.036 km/h")
