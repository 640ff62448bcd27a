"""The workbook carries the report's energy table (a conventional car's energy audit here;
a hybrid's energies, a battery-electric car's SAE J1634 energy per phase), with the values
of the page: it had no energy sheet at all."""

from __future__ import annotations

import json

from vehval.cli import main


def test_energy_audit_is_in_the_workbook_as_on_the_page(tmp_path):
    import openpyxl

    from vehval.io.parquet import read_test
    from vehval.report.html import energy_tables

    out = tmp_path / "cruze"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "steady:15mps:60s",
                 "--seed", "1", "--faults", "none", "-o", str(out)]) == 0
    files = [str(f) for f in sorted(out.glob("virtual_*"))]
    assert main(["qa", *files, "-t", str(out / "template.yaml"), "-o", str(tmp_path / "q"),
                 "--report"]) == 0
    wb = openpyxl.load_workbook(tmp_path / "q" / "tables.xlsx", read_only=True)
    assert "Energy" in wb.sheetnames
    rows = [r for r in wb["Energy"].iter_rows(values_only=True)]
    assert rows[0][0] == "Energy audit over the test (conventional)"
    assert list(rows[1]) == ["item", "energy [MJ]", "share of the fuel energy [%]"]
    sheet = {r[0]: r[1] for r in rows[2:] if r and r[0]}
    test = read_test(tmp_path / "q" / "validated.parquet")
    results = json.loads((tmp_path / "q" / "results.json").read_text())
    page = {r[0]: r[1] for r in energy_tables(test, None, None, results)[0].rows}
    assert sheet == page and isinstance(sheet["fuel energy"], float)
