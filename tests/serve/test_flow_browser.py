"""The lab flow in headless Chromium on the real Cruze files: a folder of the 10 tests under
one template opens as 10 tests, a report opens from a test, model and test identifies the car
from the other tests and predicts the opened one (kept over a reload, which keeps the tab)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from .browser_page import Visit, _wait, shot

pytestmark = [pytest.mark.browser, pytest.mark.xdist_group("serve_browser")]

TEMPLATE = Path(__file__).resolve().parents[1] / "qa" / "templates" / "cruze.yaml"


@pytest.fixture()
def cruze_ws(cruze_data, tmp_path) -> Path:
    """``WS/cruze/``: the 10 Cruze files and the one template."""
    d = tmp_path / "ws" / "cruze"
    d.mkdir(parents=True)
    for f in sorted(cruze_data.glob("*Test Data.txt")):
        shutil.copy(f, d / f.name)
    shutil.copy(TEMPLATE, d / "template.yaml")
    return d.parent


def test_cruze_folder_opens_as_tests_with_report_and_model(browser, cruze_ws):
    s = Visit(browser, cruze_ws)
    try:
        page = s.page
        page.goto(s.server.url)
        links = page.locator("#tests a")
        assert links.count() == 10
        shot(page, "many_tests")
        page.click('#tests a[href*="test=61410005_Test_Data"]')
        _wait(page, "document.body.dataset.busy === '0' && document.getElementById('summary').textContent")
        # the report of this test, built by the page and opened
        with page.context.expect_page() as opened:
            page.click("#make-report")
        report = opened.value
        report.wait_for_load_state()
        assert "61410005" in (report.title() or "") + report.content()[:5000]
        href = page.get_attribute("#report-link", "href")
        assert href.endswith("qa/61410005_Test_Data/report.html")
        assert (cruze_ws / "cruze" / "qa" / "61410005_Test_Data" / "report.html").is_file()
        report.close()
        # model and test: the vehicle named before the run, identify + predict
        page.click("button[data-tab=model]")
        _wait(page, "document.getElementById('model-vehicle').textContent")
        assert "identified from the 9 other tests" in page.text_content("#model-vehicle")
        page.click("#run-model")
        _wait(page, "document.getElementById('model-plot') && document.getElementById('model-plot').dataset.rows")
        table = page.text_content(".model-table") or ""
        assert "eudc" in table and "consistent" in table
        shot(page, "model_conventional", full_page=True)
        # a reload keeps the tab and shows the kept result without running again
        page.reload()
        _wait(page, "document.getElementById('model-out').dataset.kept === '1'")
        assert not page.is_hidden("#tab-model")
        assert "#tab=model" in page.url
        # the reader's repair of 61410004's header is shown as a note
        page.goto(s.origin + "/test?dir=cruze&test=61410004_Test_Data")
        _wait(page, "document.querySelector('.file-note')")
        assert "'fp'" in page.text_content(".file-note")
        assert not s.foreign() and not s.errors, (s.foreign(), s.errors)
    finally:
        s.close()


def test_unitless_obd_log_review(browser, real_data, tmp_path):
    """The Prius c OBD log (no units): "unit missing" rows, the to-do lines of the command
    line, and one save naming every channel without a unit."""
    src = real_data / "obd_2014_toyota_prius_c" / "output0.csv"
    if not src.is_file():
        pytest.skip(f"{src.name} not in the shared data")
    d = tmp_path / "ws" / "priusc"
    d.mkdir(parents=True)
    shutil.copy(src, d / src.name)
    s = Visit(browser, d.parent)
    try:
        page = s.page
        page.goto(s.server.url)
        page.click('#tests a[href*="priusc"]')
        _wait(page, "document.querySelectorAll('#todo-list li').length > 0 && document.querySelector('td.conf-unit')")
        n_todo = page.locator("#todo-list li").count()
        assert n_todo >= 20
        speed = page.locator('tr[data-raw="eng2vsp"] td.conf-unit')
        assert speed.text_content() == "unit missing"
        assert page.locator("td.conf-high").count() == 0      # no unit in the file: never high
        shot(page, "unitless_review")
        page.click("#save")
        _wait(page, "document.getElementById('error').textContent || document.getElementById('headline').textContent.includes('error')")
        _wait(page, "document.body.dataset.busy === '0'")
        shown = (page.text_content("#error") or "") + (page.text_content("#headline") or "")
        for raw in ("'B+'", "'Bty_Curr'", "'eng2vsp'", "'bt1'"):
            assert raw in shown, shown
        assert not s.foreign(), s.foreign()
    finally:
        s.close()
