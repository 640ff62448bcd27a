"""tables.xlsx: opens with openpyxl, its tables equal findings.json cell by cell, units in headers."""

from __future__ import annotations

import json

import numpy as np
import pytest

openpyxl = pytest.importorskip("openpyxl")

from vehval.report.excel import timeseries_frame, write_tables  # noqa: E402

from .helpers import make_control, make_qa, make_test, make_validation  # noqa: E402

pytestmark = pytest.mark.xdist_group("report_excel")


@pytest.fixture(scope="module")
def workbook(tmp_path_factory):
    path = tmp_path_factory.mktemp("xl") / "tables.xlsx"
    qa = json.loads(json.dumps(make_qa()))          # exactly what findings.json holds
    qa["findings"][0]["end_s"] = 1324.1602793520838  # needs 17 digits: "%.16G" would not round-trip
    write_tables(path, qa, make_test())
    return openpyxl.load_workbook(path, read_only=False), qa


def _table(ws, title):
    """Rows of the table whose title cell is ``title``: (header, rows)."""
    rows = [list(r) for r in ws.iter_rows(values_only=True)]
    i = next(k for k, r in enumerate(rows) if r and r[0] == title)
    header = [c for c in rows[i + 1] if c is not None]
    out = []
    for r in rows[i + 2:]:
        if all(c is None for c in r):
            break
        out.append(list(r[:len(header)]) + [None] * (len(header) - len(r)))
    return header, out


def _same(cell, value):
    if isinstance(value, (list, dict)):
        # containers are written readable (no JSON), through the one formatter
        from vehval.report.tables import plain
        return cell == plain(value) and "{" not in cell
    if isinstance(value, float):
        return cell == value                             # exact: shortest round-trip text
    return cell == value


@pytest.mark.parametrize("sheet,title,key", [("Findings", "QA findings", "findings"),
                                              ("Table2", "Table 2", "table2"),
                                              ("Table3", "Table 3", "table3")])
def test_tables_match_findings_json(workbook, sheet, title, key):
    wb, qa = workbook
    header, rows = _table(wb[sheet], title)
    expected = qa[key]
    assert header == list(expected[0].keys())
    assert len(rows) == len(expected)
    for row, exp in zip(rows, expected):
        for col, cell in zip(header, row):
            assert _same(cell, exp[col]), (sheet, col, cell, exp[col])


def test_other_sheets(workbook):
    wb, qa = workbook
    assert set(wb.sheetnames) >= {"Summary", "Findings", "Table2", "Table3", "Alignment", "Selection",
                                  "Calculations", "Mapping", "Deleted", "TimeSeries"}
    header, rows = _table(wb["Alignment"], "Alignment by source")
    assert rows[0][header.index("offset_s")] == 1.2
    header, rows = _table(wb["Selection"], "Selection: dropped")
    assert rows == [["veh_spd_obd_test", qa["selection"]["dropped"]["veh_spd_obd_test"]]]
    header, rows = _table(wb["Mapping"], "Channel mapping")
    r = rows[[x[0] for x in rows].index("veh_spd_test")]
    assert header[:6] == ["standard name", "unit (SI)", "shown as", "source", "raw name",
                          "raw unit"]
    assert r[:6] == ["veh_spd_test", "m/s", "mph", "dyno", "Dyno_Speed", "mph"]


def test_timeseries_sheet(workbook):
    wb, _ = workbook
    ws = wb["TimeSeries"]
    header = [c.value for c in ws[1]]
    assert header[0] == "time [s]" and "veh_spd_test [m/s]" in header and "eng_trq_out_test [N*m]" in header
    test = make_test()
    frame = timeseries_frame(test)
    assert ws.max_row == len(frame) + 1                  # 0.1 s grid over 300 s
    j = header.index("veh_spd_obd_test [m/s]")
    col = [ws.cell(row=i + 2, column=j + 1).value for i in range(len(frame))]
    got = np.array([np.nan if c is None else c for c in col], float)
    np.testing.assert_allclose(got, test["veh_spd_obd_test"].at(frame["time [s]"].to_numpy()),
                               rtol=1e-12, equal_nan=True)   # linear interpolation of the 1 Hz signal


def test_write_is_atomic(tmp_path, monkeypatch):
    import vehval.report.excel as xl

    def boom(*a, **k):
        raise RuntimeError("resample failed")
    monkeypatch.setattr(xl, "timeseries_frame", boom)
    with pytest.raises(RuntimeError):
        write_tables(tmp_path / "t.xlsx", make_qa(), make_test())
    assert list(tmp_path.iterdir()) == []


def test_sheet_xml_is_exact_and_well_formed():
    """Shortest round-trip text: every finite double parses back to the same bits."""
    import xml.etree.ElementTree as ET

    from vehval.report.excel import _rows_xml_chunks

    rng = np.random.default_rng(5)
    vals = rng.normal(size=(7, 3)) * np.array([1e-9, 1.0, 1e12])
    vals[0] = [0.1 + 0.2, -0.0, 1e300]
    vals[1] = [np.nan, np.inf, 5e-324]
    chunks = list(_rows_xml_chunks(vals, first_row=2, chunk_rows=3))
    assert len(chunks) == 3                                   # 3 + 3 + 1 rows
    root = ET.fromstring(b"<sheetData>" + b"".join(chunks) + b"</sheetData>")
    rows = root.findall("row")
    assert [r.get("r") for r in rows] == [str(i) for i in range(2, 9)]
    for i, row in enumerate(rows):
        cells = {c.get("r"): c.findtext("v") for c in row.findall("c")}
        for j, letter in enumerate("ABC"):
            ref = f"{letter}{i + 2}"
            if np.isfinite(vals[i, j]):
                assert float(cells[ref]) == vals[i, j], ref   # exact, not approximate
            else:
                assert ref not in cells                       # NaN/inf: empty cell


def test_control_and_validation_sheets(tmp_path):
    control, validation = make_control(), make_validation()
    path = write_tables(tmp_path / "t.xlsx", make_qa(), make_test(), control=control,
                        validation=validation)
    wb = openpyxl.load_workbook(path)
    assert {"Control", "Validation"} <= set(wb.sheetnames)
    for sheet, doc in (("Control", control["report"]), ("Validation", validation)):
        for spec in doc["tables"]:
            header, rows = _table(wb[sheet], spec["title"])
            assert header == spec["columns"][:len(header)]
            assert len(rows) == len(spec["rows"])
            for row, exp in zip(rows, spec["rows"]):
                for cell, value in zip(row, exp):
                    assert cell == value or (value is None and cell is None) or _same(cell, value), \
                        (sheet, spec["title"], cell, value)


def test_libreoffice_opens_it(tmp_path):
    """Optional: LibreOffice converts the workbook (skipped when it is not installed)."""
    import shutil
    import subprocess

    office = shutil.which("libreoffice") or shutil.which("soffice")
    if office is None:
        pytest.skip("LibreOffice not installed")
    src = tmp_path / "t.xlsx"
    write_tables(src, make_qa(), make_test())
    subprocess.run([office, "--headless", "--convert-to", "csv:Text - txt - csv (StarCalc):44,34,76,1,,0,false,true,false,false,false,-1",
                    "--outdir", str(tmp_path), str(src)], check=True, capture_output=True, timeout=120)
    ts = next(tmp_path.glob("t-TimeSeries.csv"))
    lines = ts.read_text(encoding="utf-8").splitlines()
    assert lines[0].startswith("time [s],") and len(lines) == len(timeseries_frame(make_test())) + 1
