"""Report generation: time and size of report.html and time of tables.xlsx for a long test.

Test: 10 Hz over 1,500 s, 60 channels (15,000 samples each), vehicle ``prius_2004`` (so the
engineering section draws the component maps), a QA result with findings on 20 signals.
Baseline: writing the same Test to Parquet (``vehval.io.parquet.write_test``) in the same
run, i.e. the cost of just persisting the data the report shows; every time and size is
also given as a ratio to it. Targets (absolute, from the issue): report.html under 3 s and
under 15 MB; tables.xlsx (15,000 rows x 61 columns of time series + the tables) under 2 s.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from benchmarks.common import best_of, row
from vehval.nomenclature import registry
from vehval.test import Signal, Test, TestMeta


def make_long_test(duration_s: float = 1500.0, rate_hz: float = 10.0, n_channels: int = 60,
                   seed: int = 0) -> Test:
    """A multi-channel test: smooth drive-like traces plus noise, one standard name each."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 1.0 / rate_hz)
    bases = [b for b in registry().specs if b != "time"][:n_channels]
    sigs = []
    for k, b in enumerate(bases):
        lo, hi = registry()[b].range
        mid, amp = 0.5 * (lo + hi), 0.2 * (hi - lo)
        y = mid + amp * np.sin(t / (20.0 + k)) + 0.01 * amp * rng.normal(size=t.size)
        sigs.append(Signal.standard(f"{b}_test", t, y, source="dyno", raw_name=f"CH{k}", raw_unit="-"))
    return Test(sigs, TestMeta(test_id="bench", vehicle="prius_2004", cycle="udds", files=["bench_d3.txt"],
                               synthetic=True))


def make_qa(test: Test) -> dict:
    names = test.names
    findings = [{"signal": n, "kind": "spike", "level": 1, "severity": "warning", "start_s": 100.0 + i,
                 "end_s": 101.0 + i, "message": "spike", "numbers": {"value": 1.0}, "related": []}
                for i, n in enumerate(names[:20])]
    table2 = [{"base": "x", "ref": names[i], "other": names[i + 1], "r2": 0.9, "slope": 1.0, "offset": 0.0}
              for i in range(0, 10, 2)]
    return {"test": {"test_id": "bench"}, "alignment": [], "findings": findings, "table2": table2,
            "table3": [], "calculations": [], "selection": {"dropped": {}},
            "summary": {"total": len(findings)}}


def run() -> list[dict]:
    from vehval.io.parquet import write_test
    from vehval.report import write_report, write_tables

    test = make_long_test()
    qa = make_qa(test)
    n_cells = 15_000 * (len(test) + 1)
    with tempfile.TemporaryDirectory() as d:
        html, xlsx, pq = Path(d) / "report.html", Path(d) / "tables.xlsx", Path(d) / "t.parquet"
        t_pq = best_of(lambda: write_test(test, pq), n=3)
        t_rep = best_of(lambda: write_report(html, test=test, qa=qa), n=3)
        t_xl = best_of(lambda: write_tables(xlsx, qa, test), n=3)
        size, xsize, pqsize = (p.stat().st_size / 1e6 for p in (html, xlsx, pq))
    note = "10 Hz, 1,500 s, 60 channels, 20 flagged signals, vehicle maps"
    base = "baseline: vehval.io.parquet.write_test of the same Test, same run"
    return [
        row("report_html_1500s_60ch", t_rep, "s", baseline=t_pq, note=f"{note}; {base}; target 3 s absolute"),
        row("report_html_1500s_60ch_abs", t_rep, "s", target=3.0, note=f"{note}; absolute time, target 3 s"),
        row("report_html_size", size, "MB", baseline=pqsize,
            note="plotly.js (4.8 MB) + min/max-decimated traces; baseline: the Parquet file size"),
        row("report_html_size_abs", size, "MB", target=15.0, note="absolute size, target 15 MB"),
        row("tables_xlsx_1500s_60ch", t_xl, "s", baseline=t_pq,
            note=f"{note}; {xsize:.1f} MB workbook, {n_cells:,} time-series cells; {base}; target 2 s absolute"),
        row("tables_xlsx_1500s_60ch_abs", t_xl, "s", target=2.0,
            note=f"absolute time, target 2 s ({n_cells / t_xl / 1e6:.2f} M cells/s)"),
    ]


if __name__ == "__main__":  # pragma: no cover
    for r in run():
        print(r)
