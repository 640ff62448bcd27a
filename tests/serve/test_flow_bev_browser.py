"""A battery-electric test in headless Chromium: the headline states MPGe (no fuel economy),
model and test draws its traces with one unit per axis and its J1634 tables."""

from __future__ import annotations

import pytest

from .browser_page import Visit, _wait, one_unit_per_axis, shot

pytestmark = [pytest.mark.browser, pytest.mark.xdist_group("serve_browser")]


def test_bev_page_headline_and_model(browser, bev_ws, monkeypatch):
    monkeypatch.setenv("VEHVAL_UNITS", "us")
    s = Visit(browser, bev_ws)
    try:
        page = s.page
        page.goto(s.server.url)
        page.click("#tests a[href*=\"dir=bev\"]")   # the page runs QA on open (template saved, no result yet)
        _wait(page, "document.getElementById('headline-figure')")
        figure = page.text_content("#headline-figure") or ""
        assert "MPGe" in figure and "kWh/100 mi" in figure and "mpg " not in figure + " "
        assert float(page.text_content("#headline-mpge")) > 100
        assert page.locator("#headline-mpg").count() == 0
        shot(page, "bev_test")
        with page.context.expect_page() as opened:   # the report from the page
            page.click("#make-report")
        report = opened.value
        report.wait_for_load_state()
        assert "MPGe" in report.content()
        report.close()
        page.click("button[data-tab=model]")
        _wait(page, "document.getElementById('model-vehicle').textContent")
        assert "battery_electric" in page.text_content("#model-vehicle")
        page.click("#run-model")
        _wait(page, "document.getElementById('model-plot') && document.getElementById('model-plot').dataset.rows")
        units = one_unit_per_axis(page, "model-plot")
        assert sorted(u[0] for u in units.values()) == ["A", "V", "mph"]
        tables = page.text_content("#model-out") or ""
        assert "DC battery energy" in tables and "SAE J1634 figures" in tables and "En" in tables
        shot(page, "model_bev", full_page=True)
        assert not s.foreign() and not s.errors, (s.foreign(), s.errors)
    finally:
        s.close()
