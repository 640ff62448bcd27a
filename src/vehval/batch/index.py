"""The batch index page: one self-contained HTML file linking every test report.

This module reads the run from the catalog; the page is built by
:mod:`vehval.report.batch_index` (relative links ``tests/<id>/report.html``, plotly.js
embedded once, offline).
"""

from __future__ import annotations

from pathlib import Path

from vehval.catalog import Catalog, results_variability
from vehval.io.atomic import write_text_atomic
from vehval.report.batch_index import COLUMNS, render_index_page


def index_data(catalog: Catalog, run_id: str) -> dict:
    """The plain data of the index page of run ``run_id`` (the arguments of
    :func:`vehval.report.batch_index.render_index_page`)."""
    cols = ["test_id", "status", "error", "vehicle", "cycle", "outputs", "source_run_id",
            "n_findings_by_severity", "headline_name", "headline_j1634_scope", "withheld_reason",
            "withheld_count"] \
        + [c[0] for c in COLUMNS]
    names, rows = catalog.query(f"SELECT {', '.join(cols)} FROM tests WHERE run_id = ? "
                                "ORDER BY test_id", [run_id])
    tests = [dict(zip(names, r)) for r in rows]
    removed = [t["test_id"] for t in tests if t["status"] == "removed"]
    tests = [t for t in tests if t["status"] != "removed"]
    _, run = catalog.query("SELECT started, vehval_version, n_ok, n_failed, n_skipped FROM runs "
                           "WHERE run_id = ?", [run_id])
    started, version, n_ok, n_failed, n_skipped = run[0] if run else (None, "", 0, 0, 0)
    _, phase_rows = catalog.query(
        "SELECT test_id, scope, kind, fuel_economy_mpg, fuel_economy_u_mpg FROM phase_results "
        "WHERE run_id = ? AND fuel_economy_mpg IS NOT NULL AND kind IN ('phase', 'test') "
        "ORDER BY test_id", [run_id])
    from vehval.batch.verdicts import stored_set_verdicts, verdict_line

    return {"run": {"run_id": run_id, "started": started, "vehval_version": version,
                    "n_ok": n_ok, "n_failed": n_failed, "n_skipped": n_skipped,
                    "removed": removed},
            "tests": tests, "variability": catalog.summary(),
            "results": results_variability(catalog), "phase_rows": [tuple(r) for r in phase_rows],
            "verdict_lines": [verdict_line(v) for v in stored_set_verdicts(catalog, run_id)]}


def render_index(catalog: Catalog, run_id: str) -> str:
    """HTML of the index page of run ``run_id`` (tests of the run + variability tables)."""
    return render_index_page(**index_data(catalog, run_id))


def write_index(path: str | Path, catalog: Catalog, run_id: str) -> Path:
    """Write the index page of run ``run_id`` atomically; returns its path."""
    write_text_atomic(path, render_index(catalog, run_id))
    return Path(path)
