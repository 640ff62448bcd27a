"""The workbench in headless Chromium: the unit fix, triage and catalog flows of issue 30.

A real server (uvicorn, 127.0.0.1, a free port) runs in a thread; the browser opens the URL
with the token, as a user would from the printed line. Every request the browser makes is
recorded: none may go anywhere but the workbench. Needs Debian's /usr/bin/chromium and the
python playwright package (never Playwright's browser download); skipped cleanly otherwise.
"""

from __future__ import annotations

import re

import pytest
import yaml

from vehval.catalog import open_catalog
from vehval.io.template import Template

from .browser_page import Visit, _wait, one_unit_per_axis, shot
from .helpers import FUEL_COLUMN, expected_mpg

pytestmark = [pytest.mark.browser, pytest.mark.xdist_group("serve_browser")]


def _wait_run(page, before: int) -> None:
    _wait(page, f"Number(document.body.dataset.runs || 0) > {before} "
                "&& document.body.dataset.busy === '0'")


def _runs(page) -> int:
    return int(page.evaluate("Number(document.body.dataset.runs || 0)"))


def test_unit_fix_and_triage_in_chromium(browser, workspace, synth_dir):
    init = yaml.safe_load((workspace / "virtual" / "template.yaml").read_text(encoding="utf-8"))
    s = Visit(browser, workspace)
    try:
        page = s.page
        page.goto(s.server.url)
        assert "token" not in page.url  # the token went into a cookie
        shot(page, "home")
        page.click("text=virtual")
        _wait_run(page, 0)  # the page runs QA on open (template saved, no result yet)
        summary = page.text_content("#summary") or ""
        m = re.match(r"(\d+) (finding|findings) \((\d+) (error|errors), (\d+) (warning|warnings),",
                     summary)
        assert m, summary
        for k in (1, 3, 5):                       # counts read as English: 1 finding, 2 errors
            assert (m.group(k) == "1") == (not m.group(k + 1).endswith("s")), summary
        # declare the fuel: QA reruns and the fuel row shows the unit hint
        page.select_option("#fuel", "gasoline_e0")
        n = _runs(page)
        page.click("#save")
        _wait_run(page, n)
        row = page.locator(f'tr[data-raw="{FUEL_COLUMN}"]')
        hint = row.locator(".hint").first.text_content()
        assert "fuel_rate_test" in hint
        # the impossible figure is withheld by the QA gate, naming the signal
        assert "fuel_rate_test" in page.text_content("#headline-withheld")
        # the engineer plots the channel, then fixes the unit there
        row.locator("button.plot-ch").click()
        _wait(page, f"document.getElementById('chplot').dataset.channel === '{FUEL_COLUMN}'")
        row.locator("input.ch-unit").fill("g/s")
        n = _runs(page)
        page.click("#save")
        _wait_run(page, n)
        mpg = float(page.text_content("#headline-mpg"))
        expected = expected_mpg(synth_dir, 740.0)  # gasoline_e0: 740 kg/m³
        assert mpg == pytest.approx(expected, rel=0.03)
        # the report's headline: U (k = 2), the rule, and the virtual Prius's J1711 status
        assert " ± " in (page.text_content("#headline-figure") or "")
        assert "SAE J1711" in (page.text_content("#headline-j1711") or "")
        assert "SAE J1711" in (page.text_content("#headline-lines") or "")
        shot(page, "template_review")
        assert page.locator(f'tr[data-raw="{FUEL_COLUMN}"] .hint').count() == 0
        saved = yaml.safe_load((workspace / "virtual" / "template.yaml").read_text(encoding="utf-8"))
        init["fuel"] = "gasoline_e0"
        init["files"][0]["channels"][FUEL_COLUMN]["unit"] = "g/s"
        assert saved == init  # `template init` + the two edits
        # triage: a finding opens its window; a signal is dropped with a reason
        page.click("button[data-tab=triage]")
        page.locator("#findings tr.finding").first.click()
        _wait(page, "document.getElementById('findplot').dataset.finding")
        # the plot lies under its finding, one unit per axis
        assert page.evaluate("document.getElementById('findplot').closest('tr')"
                             ".previousElementSibling.classList.contains('sel')")
        one_unit_per_axis(page, "findplot")
        shot(page, "triage")
        sel = page.locator('#selection tr[data-signal="dyno_frc_test"]')
        sel.locator("input.drop-reason").fill("load cell drifting this week")
        n = _runs(page)
        sel.locator("button.drop-btn").click()
        _wait_run(page, n)
        assert "dropped" in page.locator('#selection tr[data-signal="dyno_frc_test"]').text_content()
        final = yaml.safe_load((workspace / "virtual" / "qa" / "template_final.yaml")
                               .read_text(encoding="utf-8"))
        assert final["selection"]["drop"]["dyno_frc_test"] == "load cell drifting this week"
        init["selection"] = {"drop": {"dyno_frc_test": "load cell drifting this week"}}
        assert Template.model_validate(init).model_dump() == Template.model_validate(
            yaml.safe_load((workspace / "virtual" / "template.yaml").read_text(encoding="utf-8"))
        ).model_dump()
        assert s.errors == []
        assert s.foreign() == []
        assert any(u.endswith("/static/plotly.min.js") for u in s.requests)
    finally:
        s.close()


def test_catalog_in_chromium(browser, batch_ws):
    s = Visit(browser, batch_ws)
    try:
        page = s.page
        page.goto(s.server.url)
        page.click("text=out/catalog.duckdb")
        _wait(page, "document.body.dataset.rows === '2'")
        with open_catalog(batch_ws / "out" / "catalog.duckdb", read_only=True) as cat:
            _, rows = cat.query("SELECT test_id, headline_name, headline_mpg, headline_u_mpg "
                                "FROM latest_tests ORDER BY 1")
        for test_id, name, mpg, u in rows:
            cell = page.locator(f'tr[data-test="{test_id}"] td[data-col="headline"]')
            # the catalog's headline with its U (k = 2), in display units
            shown = "whole test" if name == "test" else name
            text = cell.text_content() or ""
            assert text.startswith(f"{shown}: {mpg:.2f} ± {u:.2f} mpg ("), (text, name, mpg, u)
        heads = page.locator("#catalog th").all_text_contents()
        assert "distance [mi]" in heads and not any("_m" in h or "_kg" in h for h in heads)
        # the table fits a 1280 px window
        page.set_viewport_size({"width": 1280, "height": 900})
        width = page.evaluate("document.getElementById('catalog').getBoundingClientRect().right")
        assert width <= 1280, width
        shot(page, "catalog")
        page.select_option('select[data-filter="cycle"]', "japan1015")
        _wait(page, "document.body.dataset.rows === '1'")
        page.select_option('select[data-filter="cycle"]', "")
        _wait(page, "document.body.dataset.rows === '2'")
        page.locator("input.pick").nth(0).check()
        page.locator("input.pick").nth(1).check()
        page.select_option("#quantity", "speed")
        page.click("#overlay")
        _wait(page, "document.getElementById('overlayplot').dataset.traces === '2'")
        assert page.locator("#overlayplot .scatterlayer .trace").count() == 2
        assert one_unit_per_axis(page, "overlayplot") == {"yaxis": ["mph"]}
        shot(page, "catalog_overlay")
        # a test's report (shared plotly.js of the batch) opens from the workbench
        href = page.locator('tr[data-test="udds"] a').get_attribute("href")
        page.goto(s.origin + href)
        _wait(page, "typeof Plotly === 'object'")
        assert s.errors == []
        assert s.foreign() == []
    finally:
        s.close()


def test_triage_after_a_restart_runs_qa_by_post(browser, workspace):
    """QA ran before this server started (qa/ on disk): the page shows its findings without a
    run; a finding's plot asks for its signals, gets 409 (a GET never runs QA), POSTs the run
    and asks again."""
    from vehval.serve.bench import Bench

    folder = (workspace / "virtual").resolve()
    assert Bench(folder).rerun().error is None
    s = Visit(browser, workspace)
    posts: list[str] = []
    s.context.on("request", lambda r: posts.append(r.url) if r.method == "POST" else None)
    try:
        page = s.page
        page.goto(s.server.url)
        page.click("text=virtual")
        _wait(page, "document.body.dataset.busy === '0'")
        assert not posts  # findings from qa/: no run on open
        page.click("button[data-tab=triage]")
        page.locator("#findings tr.finding").first.click()
        _wait(page, "document.getElementById('findplot').dataset.finding")
        assert any("/api/run" in u for u in posts)
        legend = page.text_content("#findplot") or ""
        assert "not available" not in legend and int(
            page.evaluate("document.getElementById('findplot').dataset.points")) > 0
        assert s.errors == [] or all("409" in e for e in s.errors)
        assert s.foreign() == []
    finally:
        s.close()
