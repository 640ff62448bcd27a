"""The workbench on the real Cruze D3 files in headless Chromium (skipped without
../shared): the cold UDDS 61410028's headline with U and its cell-temperature caveat; the
WLTP 61410004's results-stage finding (SAE J2951 drive quality of the high phase) listed with
QA's, its figure beside it in display units, one unit per axis."""

from __future__ import annotations

import shutil

import pytest

from helpers.data import CRUZE, CRUZE_TEMPLATE

from .browser_page import Visit, _wait, one_unit_per_axis, shot

pytestmark = [pytest.mark.browser, pytest.mark.realdata, pytest.mark.xdist_group("serve_browser")]


def _cruze_ws(tmp_path, *ids: str):
    if not CRUZE.is_dir():
        pytest.skip(f"real data not present: {CRUZE} (set VEHVAL_SHARED_DATA)")
    ws = tmp_path / "ws"
    for tid in ids:
        d = ws / tid
        d.mkdir(parents=True)
        shutil.copy(CRUZE / f"{tid} Test Data.txt", d / f"{tid} Test Data.txt")
        shutil.copy(CRUZE_TEMPLATE, d / "template.yaml")
    return ws


def _open(page, server, tid: str) -> None:
    page.goto(server.url)
    page.click(f"text={tid}")
    _wait(page, "document.body.dataset.busy === '0' && Number(document.body.dataset.runs) > 0")


def test_cold_udds_headline_and_wltp_results_finding(browser, tmp_path):
    ws = _cruze_ws(tmp_path, "61410028", "61410004")
    s = Visit(browser, ws)
    try:
        page = s.page
        _open(page, s.server, "61410028")
        figure = page.text_content("#headline-figure") or ""
        assert figure.startswith("24.60 ± 0.30 mpg ("), figure
        lines = page.text_content("#headline-lines") or ""
        assert "Caveat: cell -6.6 degC" in lines and "40 CFR 86.144" in lines, lines
        shot(page, "headline_cold_udds")
        _open(page, s.server, "61410004")
        page.click("button[data-tab=triage]")
        rows = page.locator("#findings tr.finding")
        stages = rows.evaluate_all("rs => rs.map(r => r.dataset.stage)")
        assert stages.count("results") == 1 and len(stages) == 3, stages
        dq = page.locator('#findings tr.finding[data-stage="results"]')
        assert "SAE J2951" in (dq.text_content() or "") and "IWR +4.28 %" in dq.text_content()
        dq.click()
        _wait(page, "document.getElementById('findplot').dataset.finding === "
                    "'drive_quality:veh_spd_test'")
        # beside its finding, the two sides on one axis in mph
        assert page.evaluate("document.getElementById('findplot').closest('tr')"
                             ".previousElementSibling.dataset.stage") == "results"
        assert one_unit_per_axis(page, "findplot") == {"yaxis": ["mph"]}
        shot(page, "finding_drive_quality")
        assert s.errors == [] and s.foreign() == []
    finally:
        s.close()
