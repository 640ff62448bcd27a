"""The report in real headless Chromium: renders every plot, no console error, no network.

Needs Debian's /usr/bin/chromium (``make browser`` installs it) and the python playwright
package; skipped cleanly otherwise. Playwright's own browser download is never used.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from vehval.report import write_report

from .conftest import make_qa, make_test

pytestmark = [pytest.mark.browser, pytest.mark.xdist_group("report_browser")]

CHROMIUM = os.environ.get("VEHVAL_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
LOCAL = ("file:", "data:", "about:", "blob:")


@pytest.fixture(scope="module")
def page_report(tmp_path_factory):
    if not Path(CHROMIUM).exists():
        pytest.skip("chromium not installed (run `make browser`)")
    sync_api = pytest.importorskip("playwright.sync_api")
    path = tmp_path_factory.mktemp("browser") / "report.html"
    control = {"figures": [{"title": "bar", "figure": {"data": [{"type": "bar", "x": [1, 2], "y": [1, 3]}]}}]}
    write_report(path, test=make_test(), qa=make_qa(), control=control)
    errors, remote = [], []
    with sync_api.sync_playwright() as p:
        try:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        except Exception as exc:  # noqa: BLE001 - a broken browser install is a skip, not a failure
            pytest.skip(f"chromium does not start: {exc}")
        page = browser.new_page(viewport={"width": 1300, "height": 900})
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
        page.on("pageerror", lambda e: errors.append(str(e)))

        def route(r):
            url = r.request.url
            if url.startswith(LOCAL):
                r.continue_()
            else:
                remote.append(url)
                r.abort()
        page.route("**/*", route)
        page.goto(path.as_uri())
        page.evaluate("window.vehvalReport.renderAll()")
        state = page.evaluate("""() => Array.from(document.querySelectorAll('.vv-fig')).map(el => ({
            id: el.id, rendered: el.dataset.rendered === '1',
            svg: el.querySelectorAll('.main-svg').length,
            traces: (el.data || []).length,
            drawn: el.querySelectorAll('.scatterlayer .trace, .barlayer .trace, .contourlayer .trace, '
                                       + '.sankey, .heatmaplayer .trace').length}))""")
        tables = page.evaluate("Array.from(document.querySelectorAll('table.data')).map(t => t.dataset.table)")
        # zooming one linked time plot moves the others
        ids = [s["id"] for s in state]
        linked = page.evaluate("Array.from(document.querySelectorAll('.vv-fig[data-linked]')).map(e => e.id)")
        page.evaluate(f"Plotly.relayout(document.getElementById('{linked[0]}'), {{'xaxis.range': [20, 40]}})")
        page.wait_for_timeout(300)
        other = page.evaluate(f"document.getElementById('{linked[-1]}').layout.xaxis.range")
        browser.close()
    return {"errors": errors, "remote": remote, "state": state, "tables": tables, "ids": ids, "other": other}


def test_no_console_errors(page_report):
    assert page_report["errors"] == []


def test_no_network_request(page_report):
    assert page_report["remote"] == []


def test_every_plot_rendered_with_data(page_report):
    assert len(page_report["state"]) >= 10
    for s in page_report["state"]:
        assert s["rendered"] and s["svg"] >= 1 and s["traces"] >= 1 and s["drawn"] >= 1, s


def test_every_table_present(page_report):
    for key in ("findings", "table2", "table3", "alignment", "calculations", "mapping", "deleted"):
        assert key in page_report["tables"]


def test_time_axes_linked(page_report):
    lo, hi = page_report["other"]
    assert lo == pytest.approx(20) and hi == pytest.approx(40)
