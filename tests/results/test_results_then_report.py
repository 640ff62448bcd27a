"""The README flow `vehval results` then `vehval report` on the same folder."""

import json

from .helpers import cli_files


def test_results_then_report_on_the_same_folder(tmp_path, cli):
    raw, tpl = cli_files(tmp_path)
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


def _doc():
    block = {"name": "bag1", "values": {"distance_m": 5_780.0, "duration_s": 505.0,
                                        "mean_speed_mps": 11.45, "max_speed_mps": 25.47,
                                        "fuel_mass_kg": 0.399, "fuel_economy_mpg": 28.98,
                                        "fuel_consumption_l_per_100km": 8.12},
             "uncertainty": {"fuel_economy_mpg": {"U": 0.35},
                             "fuel_consumption_l_per_100km": {"U": 0.10}},
             "drive_quality": {"iwr_pct": 3.4, "rmsse_mps": 0.1462, "rmsse_mph": 0.327}}
    comp = {"name": "ftp75_from_udds", "values": block["values"], "rule": "r",
            "uncertainty": block["uncertainty"], "substitute": "bag 3 taken as bag 2",
            "caveats": ["substitute: bag 3 taken as bag 2"]}
    return {"phases": [block], "test_total": block, "composites": [comp],
            "headline": {"name": "ftp75_from_udds", "kind": "composite",
                         "fuel_economy_mpg": 28.98, "fuel_economy_u_mpg": 0.35,
                         "fuel_consumption_l_per_100km": 8.12}}


def test_results_section_follows_the_unit_system(monkeypatch):
    """`vehval --units metric report` gave mi, mph and mpg first in the results section."""
    from vehval.report.results_view import results_section
    from vehval.report.sections import headline_banner

    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    sec = results_section(_doc())
    phases = next(t for t in sec.tables if t.title == "Results per phase")
    assert phases.columns[1] == "distance [km]" and phases.columns[3] == "mean speed [km/h]"
    assert phases.columns[6:8] == ["consumption [L/100 km]", "fuel economy [mpg]"]
    assert phases.rows[0][1] == 5.78 and phases.rows[0][3] == 41.22
    assert phases.rows[0][6] == "8.12 ± 0.10" and phases.rows[0][-2] == 0.526   # RMSSE km/h
    assert headline_banner(_doc())["title"].split(": ", 1)[1].startswith("8.12 ± 0.10 L/100 km")
    comp = next(t for t in sec.tables if t.title == "Regulatory composites")
    assert comp.rows[0][-1] == "none"            # the substitute is not repeated as a caveat
    monkeypatch.setenv("VEHVAL_UNITS", "us")
    phases = next(t for t in results_section(_doc()).tables if t.title == "Results per phase")
    assert phases.columns[1] == "distance [mi]" and phases.columns[6] == "fuel economy [mpg]"
    assert phases.rows[0][1] == 3.592 and phases.rows[0][-2] == 0.327
    assert headline_banner(_doc())["title"].split(": ", 1)[1].startswith("28.98 ± 0.35 mpg")


def test_conditions_without_a_cell_temperature_read_not_measured():
    """A log without an ambient channel showed 'cell None °C' in the report."""
    from vehval.report.results_view import results_section

    facts = dict(results_section({"conditions": {"cell_temp_c": None, "start": None}}).facts)
    assert facts["Conditions"] == "cell temperature not measured, unknown start"
    facts = dict(results_section({"conditions": {"cell_temp_c": 23.456, "start": "hot"}}).facts)
    assert facts["Conditions"] == "cell 23.5 °C, hot start"
