"""Model and test in headless Chromium for each architecture validated by simulation: a
battery-electric test (the headline states MPGe, no fuel economy; the traces with one unit
per axis and the J1634 tables) and a power-split hybrid (the fuel mass's En)."""

from __future__ import annotations

import shutil

import pytest

from .browser_page import Visit, _wait, one_unit_per_axis, shot

pytestmark = [pytest.mark.browser, pytest.mark.xdist_group("serve_browser")]


def test_bev_page_headline_and_model(browser, bev_ws, monkeypatch):
    monkeypatch.setenv("VEHVAL_UNITS", "us")
    monkeypatch.chdir(bev_ws)   # the template names its vehicle file from there
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


def test_power_split_model_page(browser, synth_dir, tmp_path):
    """The virtual Prius under its template (naming prius_2004): model and test draws speed,
    engine speed, SOC... one unit per axis, beside the fuel mass's En."""
    d = tmp_path / "ws" / "prius"
    d.mkdir(parents=True)
    for f in (*synth_dir.glob("*_d3.txt"), *synth_dir.glob("*_obd.csv"),
              synth_dir / "template.yaml"):
        shutil.copy(f, d / f.name)
    s = Visit(browser, tmp_path / "ws")
    try:
        page = s.page
        page.goto(s.server.url)
        page.click("#tests a[href*=\"dir=prius\"]")
        _wait(page, "document.getElementById('headline-figure')")
        page.click("button[data-tab=model]")
        _wait(page, "document.getElementById('model-vehicle').textContent")
        assert "power_split" in page.text_content("#model-vehicle")
        page.click("#run-model")
        _wait(page, "document.getElementById('model-plot') && document.getElementById('model-plot').dataset.rows")
        units = one_unit_per_axis(page, "model-plot")
        assert {"rpm", "%"} <= {u[0] for u in units.values()}
        assert "normalised error (fuel mass)" in (page.text_content("#model-out") or "")
        shot(page, "model", full_page=True)
        assert not s.foreign() and not s.errors, (s.foreign(), s.errors)
    finally:
        s.close()
