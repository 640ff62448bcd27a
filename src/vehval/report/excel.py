"""Excel export: every table of the report and the validated time series in ``tables.xlsx``.

Sheets: ``Summary``, ``Findings``, ``Table2``, ``Table3``, ``Alignment``, ``Selection``,
``Calculations``, ``Mapping`` (raw → standard names and units), ``Deleted`` and ``TimeSeries``
(every signal resampled to one grid, header ``name [unit]``). Cells hold the same values as
``findings.json`` (nested values as JSON text). Written with xlsxwriter, atomically.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
import zipfile
from typing import Any, Iterator

import numpy as np

from vehval.io.atomic import atomic_path
from vehval.report import qa_view as qv
from vehval.report import sections as S
from vehval.report.tables import Table, rows_table, to_tables
from vehval.test import Test

MAX_SHEET_ROWS = 1_048_575


def qa_tables(qa: Any, test: Test | None = None) -> dict[str, list[Table]]:
    """The tables of the report grouped by sheet name."""
    q = qv.as_dict(qa)
    sheets: dict[str, list[Table]] = {}
    facts = []
    if test is not None:
        m = test.meta
        dur, dist = S.duration_and_distance(test)
        facts = [["test_id", m.test_id], ["vehicle", m.vehicle], ["cycle", m.cycle],
                 ["template", m.template], ["files", "; ".join(m.files)], ["duration [s]", dur],
                 ["distance [m]", dist], ["signals", len(test)], ["synthetic", bool(m.synthetic)]]
        facts += [[f"constant {k}", v] for k, v in m.constants.items()]
        facts += [[f"offset_s {k}", v] for k, v in m.offsets_s.items()]
    summary = [Table("Test", ["item", "value"], facts, key="test")] if facts else []
    if q.get("summary") is not None:
        summary += to_tables(q["summary"], "QA summary", key="qa-summary")
    sheets["Summary"] = summary
    sheets["Findings"] = [rows_table("QA findings", qv.as_rows(q.get("findings")), key="findings")]
    sheets["Table2"] = [rows_table("Table 2", qv.as_rows(q.get("table2")), key="table2")]
    sheets["Table3"] = [rows_table("Table 3", qv.as_rows(q.get("table3")), key="table3")]
    results = S.alignment_results(q.get("alignment"))
    al = [rows_table("Alignment by source", [{k: v for k, v in r.items() if k != "pairs"} for r in results])]
    pairs = [{"source": r.get("source"), **p} for r in results for p in qv.as_rows(r.get("pairs"))]
    if pairs:
        al.append(rows_table("Alignment pairs", pairs))
    sheets["Alignment"] = al
    sheets["Selection"] = to_tables(q.get("selection"), "Selection") or [rows_table("Selection", [])]
    sheets["Calculations"] = to_tables(q.get("calculations"), "Calculations") or [rows_table("Calculations", [])]
    if test is not None:
        imp = S.import_section(test)
        sheets["Mapping"], sheets["Deleted"] = imp.tables[:1], imp.tables[1:]
    return sheets


def timeseries_frame(test: Test, dt: float | None = None):
    """All signals on one uniform grid; columns ``name [unit]``, first column ``time [s]``.

    Parameters
    ----------
    dt : float, optional
        Grid step [s]; default the shortest median sample period of the test (at least
        1 ms), limited so that the sheet fits Excel's row limit.
    """
    periods = [s.sample_period for s in test if np.isfinite(s.sample_period) and s.sample_period > 0]
    t0, t1 = test.span()
    if dt is None:
        dt = max(min(periods) if periods else 1.0, 1e-3)
    dt = max(dt, (t1 - t0) / (MAX_SHEET_ROWS - 2))
    frame, _ = test.resample(dt)
    units = frame.attrs.get("units", {})
    frame.columns = [f"{c} [{units.get(c, '')}]" for c in frame.columns]
    frame.insert(0, "time [s]", frame.index.to_numpy())
    return frame.reset_index(drop=True)


def _write_tables(ws, tables: list[Table], fmt: dict) -> None:
    row = 0
    widths: dict[int, int] = {}
    for t in tables:
        ws.write(row, 0, t.title, fmt["title"])
        row += 1
        for j, c in enumerate(t.columns):
            ws.write_string(row, j, c, fmt["head"])
            widths[j] = max(widths.get(j, 8), min(len(c) + 2, 40))
        row += 1
        for r in t.rows:
            for j, v in enumerate(r):
                if v is None:
                    continue
                if isinstance(v, bool):
                    ws.write_boolean(row, j, v)
                elif isinstance(v, (int, float)):
                    if np.isfinite(v):
                        ws.write_number(row, j, v)
                else:
                    s = str(v)
                    ws.write_string(row, j, s)
                    widths[j] = max(widths.get(j, 8), min(len(s) + 2, 60))
            row += 1
        row += 1
    for j, w in widths.items():
        ws.set_column(j, j, w)


def _col_letter(j: int) -> str:
    out = ""
    j += 1
    while j:
        j, r = divmod(j - 1, 26)
        out = chr(65 + r) + out
    return out


def _rows_xml(values: np.ndarray, first_row: int) -> Iterator[str]:
    """``<row>`` elements of a numeric block (NaN/inf cells left empty)."""
    letters = [_col_letter(j) for j in range(values.shape[1])]
    finite = np.isfinite(values)
    for i, (vals, ok) in enumerate(zip(values.tolist(), finite.tolist())):
        r = i + first_row
        cells = "".join(f'<c r="{c}{r}"><v>{v!r}</v></c>' for c, v, good in zip(letters, vals, ok) if good)
        yield f'<row r="{r}">{cells}</row>'


def _inject_rows(xlsx: Path, member: str, values: np.ndarray) -> None:
    """Append ``values`` as rows 2.. of a worksheet that xlsxwriter wrote with a header row only.

    xlsxwriter spends ~20 µs a cell in Python; a 10 Hz, 1,500 s, 60-channel time series
    (900,000 cells) is instead formatted here as sheet XML directly (Python's shortest
    round-trip float repr, so values are exact) and the package is re-zipped.
    """
    with zipfile.ZipFile(xlsx) as zin:
        items = [(info, zin.read(info.filename)) for info in zin.infolist()]
    tmp2 = xlsx.with_name(xlsx.name + ".rows")
    try:
        with zipfile.ZipFile(tmp2, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zout:
            for info, data in items:
                if info.filename != member:
                    zout.writestr(info, data, compress_type=zipfile.ZIP_DEFLATED)
                    continue
                xml = data.decode("utf-8")
                last = f"{_col_letter(values.shape[1] - 1)}{values.shape[0] + 1}"
                xml = re.sub(r'<dimension ref="[^"]*"/>', f'<dimension ref="A1:{last}"/>', xml, count=1)
                end = xml.index("</sheetData>")
                with zout.open(info.filename, "w") as fh:
                    fh.write(xml[:end].encode("utf-8"))
                    chunk: list[str] = []
                    for row_xml in _rows_xml(values, 2):
                        chunk.append(row_xml)
                        if len(chunk) >= 2000:
                            fh.write("".join(chunk).encode("utf-8"))
                            chunk = []
                    fh.write("".join(chunk).encode("utf-8"))
                    fh.write(xml[end:].encode("utf-8"))
        os.replace(tmp2, xlsx)
    finally:
        tmp2.unlink(missing_ok=True)


def write_tables(path: str | Path, qa: Any, test: Test | None = None, *, dt: float | None = None) -> Path:
    """Write ``tables.xlsx``: the report tables, one sheet per group, and the time series.

    Parameters
    ----------
    path : str or Path
        Output workbook (written atomically).
    qa : dict or QAResult or None
        QA result (``findings.json`` structure).
    test : Test, optional
        Validated test: adds the summary, mapping and ``TimeSeries`` sheets.
    dt : float, optional
        Time-series grid step [s] (see :func:`timeseries_frame`).

    Returns
    -------
    Path
        The written file.
    """
    import xlsxwriter

    with atomic_path(path) as tmp:
        wb = xlsxwriter.Workbook(str(tmp), {"nan_inf_to_errors": True, "strings_to_numbers": False,
                                            "strings_to_formulas": False, "strings_to_urls": False})
        fmt = {"title": wb.add_format({"bold": True, "font_size": 12}),
               "head": wb.add_format({"bold": True, "bg_color": "#E9EEF3", "bottom": 1})}
        for name, tables in qa_tables(qa, test).items():
            ws = wb.add_worksheet(name)
            _write_tables(ws, tables, fmt)
            ws.freeze_panes(2, 0)
        frame = None
        if test is not None and len(test):
            frame = timeseries_frame(test, dt)
            ws = wb.add_worksheet("TimeSeries")
            ws.write_row(0, 0, list(frame.columns), fmt["head"])
            ws.freeze_panes(1, 1)
            ws.set_column(0, len(frame.columns) - 1, 14)
            ts_index = len(wb.worksheets())
        wb.close()
        if frame is not None:
            _inject_rows(tmp, f"xl/worksheets/sheet{ts_index}.xml", frame.to_numpy(dtype=float))
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the usual file mode
    return Path(path)
