"""Reports: one self-contained HTML file per test or validation, an Excel export, plots.

Public API
----------
:func:`write_report`
    ``report.html`` of one test with its QA result (and control/validation when given).
:func:`write_tables`
    ``tables.xlsx`` with every table of the report and the validated time series.
:func:`build_reports`
    Both at once into an output directory (what ``vehval report``, ``vehval validate
    --report`` and the batch runner call).
:func:`results_beside`
    ``findings.json`` / ``control.json`` stored next to a validated test.
:func:`write_plotly_asset`
    One shared local copy of plotly.js for many reports (``plotly_js="<relative path>"``,
    what the batch runner uses); single reports embed it by default.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vehval.io.atomic import atomic_dir
from vehval.report.excel import write_tables
from vehval.report.html import (
    INLINE,
    energy_tables,
    plotly_asset_name,
    render_report,
    write_plotly_asset,
    write_report,
)
from vehval.report.inputs import load_json, results_beside
from vehval.test import Test

__all__ = ["build_reports", "write_report", "write_tables", "render_report", "load_json",
           "results_beside", "write_plotly_asset", "plotly_asset_name"]


def build_reports(outdir: str | Path, test: Test, qa: Any = None, template: Any = None,
                  vehicle: Any = None, control: Any = None, validation: dict | None = None,
                  *, title: str | None = None, html_name: str = "report.html",
                  excel_name: str = "tables.xlsx", raw: Test | None = None,
                  plotly_js: str = INLINE, results: Any = None) -> dict[str, Path]:
    """Write ``report.html`` and ``tables.xlsx`` into ``outdir``.

    Both files are staged and moved in only when both succeeded, so a failed run leaves
    neither a partial nor a mismatched pair.

    Parameters
    ----------
    outdir : str or Path
        Output directory (created if needed; other files in it are kept).
    test : Test
        Validated test.
    qa : dict or QAResult or None
        QA result (``findings.json`` structure).
    template, vehicle, control, validation, title, raw, plotly_js, results
        As for :func:`write_report`; the control and validation tables also get their own
        sheets in the workbook.

    Returns
    -------
    dict
        ``{"report": Path, "tables": Path}``.
    """
    outdir = Path(outdir)
    html = render_report(test, qa, template=template, vehicle=vehicle, control=control,
                         validation=validation, title=title, raw=raw, plotly_js=plotly_js,
                         results=results)
    with atomic_dir(outdir, whole=False) as stage:
        (stage / html_name).write_text(html, encoding="utf-8")
        write_tables(stage / excel_name, qa, test, control=control, validation=validation,
                     results=results, energy=energy_tables(test, vehicle, template, results))
    return {"report": outdir / html_name, "tables": outdir / excel_name}
