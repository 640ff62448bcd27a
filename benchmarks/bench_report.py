"""Report generation: time and size of report.html (and tables.xlsx) for a long test.

Test: 10 Hz over 1,500 s, 60 channels (15,000 samples each), a QA result with findings on
20 signals. Baseline: writing the same Test to Parquet (``vehval.io.parquet.write_test``)
in the same run, i.e. the cost of just persisting the data the report shows.
Targets: report under 3 s and under 15 MB.
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
    return Test(sigs, TestMeta(test_id="bench", cycle="udds", files=["bench_d3.txt"], synthetic=True))


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
    with tempfile.TemporaryDirectory() as d:
        html, xlsx, pq = Path(d) / "report.html", Path(d) / "tables.xlsx", Path(d) / "t.parquet"
        t_rep = best_of(lambda: write_report(html, test=test, qa=qa), n=3)
        t_pq = best_of(lambda: write_test(test, pq), n=3)
        t_xl = best_of(lambda: write_tables(xlsx, qa, test), n=1, warmup=0)
        size = html.stat().st_size / 1e6
        xsize = xlsx.stat().st_size / 1e6
    note = "10 Hz, 1,500 s, 60 channels, 20 flagged signals"
    return [
        row("report_html_1500s_60ch", t_rep, "s", baseline=t_pq, note=f"{note}; target 3 s on value; "
            "baseline vehval.io.parquet.write_test of the same Test", target=None),
        row("report_html_1500s_60ch_abs", t_rep, "s", target=3.0, note=f"{note}; absolute time"),
        row("report_html_size", size, "MB", target=15.0, note="plotly.js (4.8 MB) + min/max-decimated traces"),
        row("tables_xlsx_1500s_60ch", t_xl, "s", baseline=t_pq, note=f"{note}; {xsize:.1f} MB workbook, "
            "time series on a 0.1 s grid; baseline Parquet write"),
    ]


if __name__ == "__main__":  # pragma: no cover
    for r in run():
        print(r)
