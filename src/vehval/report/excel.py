"""Excel export: every table of the report and the validated time series in ``tables.xlsx``.

Sheets: ``Summary``, ``Findings``, ``Table2``, ``Table3``, ``Alignment``, ``Selection``,
``Calculations``, ``Mapping`` (raw → standard names and units), ``Deleted``, ``Energy`` (the
energy tables of the report, when given), ``Control`` and
``Validation`` (when given) and ``TimeSeries`` (every signal resampled to one grid, header
``name [unit]``). Each table sheet stacks its tables: a bold title row, a header row, the
rows, a blank row. Cells hold the same values as ``findings.json`` (nested values as JSON
text). The table sheets are written with xlsxwriter; the time series, which is most of the
cells, is formatted as sheet XML by Arrow kernels (see :func:`_rows_xml_chunk`). Written
atomically.
"""

from __future__ import annotations

import os
import re
import zipfile
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from itertools import islice
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from vehval.io.atomic import atomic_path
from vehval.report import qa_view as qv
from vehval.report import sections as S
from vehval.report.tables import Table, rows_table, to_tables
from vehval.test import Test

MAX_SHEET_ROWS = 1_048_575
CHUNK_ROWS = 2048  # time-series rows formatted per chunk


def qa_tables(qa: Any, test: Test | None = None) -> dict[str, list[Table]]:
    """The tables of the report grouped by sheet name."""
    q = qv.as_dict(qa)
    sheets: dict[str, list[Table]] = {}
    facts: list[list[Any]] = []
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
    """Excel column letters of the 0-based column ``j`` (0 -> A, 26 -> AA)."""
    out = ""
    j += 1
    while j:
        j, r = divmod(j - 1, 26)
        out = chr(65 + r) + out
    return out


def _rows_xml_chunk(columns: np.ndarray, start: int, stop: int, first_row: int,
                    letters: list[str]) -> bytes:
    """``<row>`` elements of rows ``start:stop`` of a column-major block as UTF-8 XML.

    Built column-wise with Arrow compute kernels (no Python loop over cells): each float is
    cast to its shortest round-trip decimal text (exact: parsing it gives the same IEEE
    double), joined into ``<c r="B7"><v>…</v></c>`` cells and the cells into rows. NaN and
    infinite samples have no cell at all (an empty cell in Excel). Arrow releases the GIL,
    so chunks can be built in threads.

    Parameters
    ----------
    columns : numpy.ndarray
        2-D float array, one row per sheet *column* (``values.T``, C-contiguous).
    start, stop : int
        Sheet rows to format, as indices into the second axis of ``columns``.
    first_row : int
        1-based sheet row of index 0.
    letters : list of str
        Column letters (``A``, ``B``...).
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    rnum = pc.cast(pa.array(np.arange(first_row + start, first_row + stop, dtype=np.int64)), pa.string())
    cells = []
    for letter, col in zip(letters, columns[:, start:stop]):
        ok = np.isfinite(col)
        full = bool(ok.all())
        text = pc.cast(pa.array(col, mask=None if full else ~ok), pa.string())
        # a null value makes the whole cell null, then an empty string: no cell
        cell = pc.binary_join_element_wise(f'<c r="{letter}', rnum, '"><v>', text, "</v></c>", "")
        cells.append(cell if full else pc.fill_null(cell, ""))
    rows = pc.binary_join_element_wise('<row r="', rnum, '">', *cells, "</row>", "")
    offsets = np.frombuffer(rows.buffers()[1], dtype=np.int32, count=len(rows) + 1, offset=rows.offset * 4)
    return memoryview(rows.buffers()[2])[offsets[0]:offsets[-1]].tobytes()


def _rows_xml_chunks(values: np.ndarray, first_row: int, chunk_rows: int = CHUNK_ROWS,
                     workers: int = 2) -> Iterator[bytes]:
    """``<row>`` elements of a numeric block as UTF-8 XML, ``chunk_rows`` rows at a time, in order.

    Chunks are built by :func:`_rows_xml_chunk` in ``workers`` threads, at most
    ``workers + 1`` ahead of the consumer (bounded memory whatever the sheet size).

    Parameters
    ----------
    values : numpy.ndarray
        2-D float array, one row per sheet row.
    first_row : int
        1-based sheet row of ``values[0]``.
    chunk_rows : int
        Rows per chunk (also bounds Arrow's 2 GiB string-array limit).
    workers : int
        Threads building chunks (1: build in the calling thread's pool of one).
    """
    columns = np.ascontiguousarray(np.asarray(values, float).T)
    letters = [_col_letter(j) for j in range(columns.shape[0])]
    starts = iter(range(0, columns.shape[1], chunk_rows))
    with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
        def submit(start: int):
            stop = min(start + chunk_rows, columns.shape[1])
            return pool.submit(_rows_xml_chunk, columns, start, stop, first_row, letters)

        pending = deque(submit(st) for st in islice(starts, max(1, workers) + 1))
        while pending:
            chunk = pending.popleft().result()
            nxt = next(starts, None)
            if nxt is not None:
                pending.append(submit(nxt))
            yield chunk


def _inject_rows(xlsx: Path, member: str, values: np.ndarray) -> None:
    """Append ``values`` as rows 2.. of a worksheet that xlsxwriter wrote with a header row only.

    xlsxwriter spends ~20 µs a cell in Python; a 10 Hz, 1,500 s, 60-channel time series
    (900,000 cells) is instead formatted as sheet XML by :func:`_rows_xml_chunks` (two
    threads) and streamed into the re-zipped package (deflate level 1) by this thread: Arrow
    and zlib both release the GIL, so formatting and compression overlap.
    """
    with zipfile.ZipFile(xlsx) as zin:
        items = [(info, zin.read(info.filename)) for info in zin.infolist()]
    tmp2 = xlsx.with_name(xlsx.name + ".rows")
    big = values.size * 48 > (1 << 30)  # uncompressed sheet may pass 2 GiB: ZIP64 entry
    try:
        with zipfile.ZipFile(tmp2, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zout:
            for info, data in items:
                if info.filename != member:
                    zout.writestr(info, data, compress_type=zipfile.ZIP_DEFLATED, compresslevel=1)
                    continue
                xml = data.decode("utf-8")
                last = f"{_col_letter(values.shape[1] - 1)}{values.shape[0] + 1}"
                xml = re.sub(r'<dimension ref="[^"]*"/>', f'<dimension ref="A1:{last}"/>', xml, count=1)
                end = xml.index("</sheetData>")
                with zout.open(info.filename, "w", force_zip64=big) as fh:
                    fh.write(xml[:end].encode("utf-8"))
                    for chunk in _rows_xml_chunks(values, 2):
                        fh.write(chunk)
                    fh.write(xml[end:].encode("utf-8"))
        os.replace(tmp2, xlsx)
    finally:
        tmp2.unlink(missing_ok=True)


def _exact_worksheet_class():
    """xlsxwriter worksheet writing numbers as shortest round-trip text (``repr``).

    xlsxwriter writes ``%.16G``, one digit short of exact: a JSON value such as
    ``1324.1602793520838`` would come back as ``1324.160279352084``. The override keeps the
    table sheets equal to ``findings.json`` bit for bit.
    """
    from xlsxwriter.worksheet import Worksheet

    class ExactWorksheet(Worksheet):
        def _xml_number_element(self, number, attributes=[]) -> None:  # noqa: B006 - xlsxwriter's signature
            attr = "".join(f' {k}="{self._escape_attributes(v)}"' for k, v in attributes)
            self.fh.write(f"<c{attr}><v>{float(number)!r}</v></c>")

    return ExactWorksheet


def plugin_tables(control: Any = None, validation: Any = None) -> dict[str, list[Table]]:
    """The ``Control`` and ``Validation`` sheets: the tables of those report sections."""
    from vehval.report.plugins import control_section, validation_section

    sheets: dict[str, list[Table]] = {}
    if control is not None:
        sheets["Control"] = control_section(qv.as_dict(control)).tables
    if validation is not None:
        sheets["Validation"] = validation_section(qv.as_dict(validation)).tables
    return {k: v or [rows_table(k, [])] for k, v in sheets.items()}


def _numbers_with_u(t: Table) -> Table:
    """``t`` with each column of ``value ± U`` cells as two number columns: the value and
    ``U (k = 2) <column>``; "—" (no figure) an empty cell, "withheld" stays text."""
    from vehval.report.results_view import PlusMinus

    pm = {j for r in t.rows for j, v in enumerate(r) if isinstance(v, PlusMinus)}
    cols = [x for j, c in enumerate(t.columns) for x in ([c, f"U (k = 2) {c}"] if j in pm else [c])]
    rows = []
    for r in t.rows:
        row: list[Any] = []
        for j, v in enumerate(r):
            if j not in pm:
                row.append(None if v == "—" else v)
            elif isinstance(v, PlusMinus):
                row += [v.value, v.u]
            else:
                row += [None if v == "—" else v, None]
        rows.append(row)
    return Table(t.title, cols, rows, key=t.key, note=t.note)


def results_tables(results: Any = None) -> dict[str, list[Table]]:
    """The ``Results`` sheet: the headline and the results section's tables (a withheld
    figure reads "withheld", never a number; a ``value ± U`` cell is two numbers)."""
    if results is None:
        return {}
    from vehval.report.results_view import results_section

    doc = qv.as_dict(results)
    tables = []
    banner = S.headline_banner(doc)
    if banner is not None:
        tables.append(Table("Headline", ["headline", "detail"],
                            [[banner["title"], line] for line in banner["lines"] or [""]],
                            key="results-headline"))
    tables += [_numbers_with_u(t) for t in results_section(doc).tables]
    return {"Results": tables}


def write_tables(path: str | Path, qa: Any, test: Test | None = None, *, dt: float | None = None,
                 control: Any = None, validation: Any = None, results: Any = None,
                 energy: list[Table] | None = None) -> Path:
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
    control, validation : dict, optional
        ``control.json`` / ``validation.json``: their report tables in the ``Control`` and
        ``Validation`` sheets.
    results : dict, optional
        ``results.json``: the ``Results`` sheet (first).
    energy : list of Table, optional
        The report's energy tables (:func:`vehval.report.html.energy_tables`): the
        ``Energy`` sheet.

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
        exact = _exact_worksheet_class()
        for name, tables in {**results_tables(results), **qa_tables(qa, test),
                             **({"Energy": energy} if energy else {}),
                             **plugin_tables(control, validation)}.items():
            ws = wb.add_worksheet(name, worksheet_class=exact)
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
