"""Every HTML page vehval writes, built from hostile text in every text field.

A Test Car List is a downloaded file, a test's channel names and units come from the raw
files, ``validation.json`` / ``control.json`` / ``results.json`` may be written by other
tools: none of their text may become markup. Each page (QA report with results, control
and validation, EPA validation report, identification and prediction pages, batch index,
sensitivity page) is rendered from such values; the text must appear escaped, the page
must carry no event-handler attribute and no script other than its own (hashed in its
Content-Security-Policy). In headless Chromium (as in ``test_browser.py``): no script of the
payload runs (no dialog, title unchanged), no request leaves the page, no CSP violation,
and every plot is drawn.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest
from markupsafe import escape

from helpers.browser import ARGS, CHROMIUM, LOCAL
from vehval.report import write_report
from vehval.report.safety import script_hash

from .helpers import make_control, make_qa, make_test, make_validation

PAYLOAD = ("<svg onload=alert(1)>\"><script>document.title='pwned'</script>"
           "&#x3C;img src=x onerror=alert(2)&#x3E;</script><script>alert(3)</script>")


def hostile(tag: str) -> str:
    """A hostile text carrying a field tag (to find it on the page)."""
    return f"{tag}{PAYLOAD}"


# ------------------------------------------------------------------------- the pages
def _qa_report(root: Path) -> tuple[Path, list[str]]:
    test = make_test()
    m = test.meta
    m.test_id, m.cycle, m.vehicle = hostile("testid"), hostile("cycle"), hostile("vehname")
    m.files, m.template = [hostile("rawfile")], hostile("tmplfile")
    m.deleted = [{"channel": hostile("delchan"), "file": hostile("delfile"), "reason": hostile("delwhy")}]
    for s in test:
        s.raw_name, s.raw_unit, s.file = hostile("rawname"), hostile("rawunit"), hostile("sigfile")
    qa = make_qa()
    for f in qa["findings"]:
        f["message"] = hostile("qamsg")
    qa["findings"][0]["signal"] = hostile("qasig")
    qa["table2"][0]["unit"] = hostile("qaunit")
    qa["calculations"][0]["equation"] = hostile("qaeq")
    control = make_control()
    control["report"]["title"] = hostile("ctltitle")
    for t in control["report"]["tables"]:
        t["title"], t["columns"][0] = hostile("ctltable"), hostile("ctlcol")
        if t["rows"]:
            t["rows"][0][0] = hostile("ctlcell")
    validation = make_validation()
    validation["notes"] = [hostile("valnote")]
    validation["tables"][0]["title"] = hostile("valtable")
    validation["tables"][0]["columns"][0] = hostile("valcol")
    validation["tables"][0]["rows"][0][0] = hostile("valcell")
    fig = validation["figures"][0]
    (fig["figure"] if "figure" in fig else fig)["data"][0]["name"] = hostile("valtrace")
    if "figure" in fig:
        fig["title"] = hostile("valfig")
    results = {"test": {"cycle": hostile("rescycle")}, "phase_source": hostile("resphases"),
               "fuel": {"name": hostile("resfuel"), "density_kg_per_m3": 745.0, "lhv_j_per_kg": 42.6e6},
               "conditions": {"cell_temp_c": 23.0, "start": hostile("resstart")},
               "uncertainty": {"method": hostile("resmethod"),
                               "accuracy": {hostile("resacc"): {"reading_pct": 1.0, "offset_si": 0.0,
                                                                "basis": hostile("resbasis")}}},
               "soc_correction": {"message": hostile("ressoc")},
               "phases": [{"name": hostile("resphase"), "values": {"fuel_economy_mpg": 50.0}}],
               "test_total": {"name": "whole test", "values": {"fuel_economy_mpg": 50.0}},
               "composites": [{"name": hostile("rescomp"), "values": {"fuel_economy_mpg": 51.0},
                               "rule": hostile("resrule")}],
               "notes": [hostile("resnote")]}
    path = root / "report.html"
    write_report(path, test=test, qa=qa, template=hostile("tmpldesc"), control=control,
                 validation=validation, results=results)
    shown = ["testid", "cycle", "rawfile", "tmpldesc", "delchan", "delfile", "delwhy", "rawname",
             "rawunit", "qamsg", "qasig", "qaunit", "qaeq", "ctltable", "ctlcol", "ctlcell",
             "valnote", "valtable", "valcol", "valcell", "rescycle", "resphases", "resfuel",
             "resstart", "resacc", "resbasis", "ressoc", "resphase", "rescomp", "resrule", "resnote"]
    return path, shown


EPA_TEXT = {"Vehicle Manufacturer Name": "epamfr", "Represented Test Veh Make": "epamake",
            "Test Vehicle ID": "epavid", "Test Number": "epanum", "Test Originator": "epaorig",
            "Test Fuel Type Description": "epafuel"}


def _epa_report(root: Path) -> tuple[Path, list[str]]:
    from helpers.epa_lists import row, write_list
    from vehval.cli import main

    def bad(r: dict) -> dict:
        out = {**r, **{col: hostile(tag) for col, tag in EPA_TEXT.items()}}
        out["Test Fuel Type Description"] += " Gasoline"   # still runnable
        return out

    lst = write_list(root / "list.csv", [
        bad(row(number="T1", code=3, desc="HWFE", fe=71.2)),
        {**bad(row(number="T5", orig="MFR", code=95, desc="SC03", fe=58.8)),
         "Test Procedure Description": hostile("epadesc")}])
    assert main(["epa", "validate", str(lst), "--vehicle", "prius_2016", "--tests",
                 "model=PRIUS", "--dt", "1", "-o", str(root / "epa")]) == 0
    return root / "epa" / "report.html", ["epanum", "epaorig", "epadesc"]


def _identification_pages(root: Path) -> list[tuple[Path, list[str]]]:
    from vehval.report.identify_page import write_identification_page, write_prediction_page

    t = np.arange(0.0, 60.0, 0.5)
    fig = {"data": [{"type": "scattergl", "x": t, "y": np.sin(t), "name": hostile("idtrace")}],
           "layout": {"title": {"text": hostile("idfig")}, "xaxis": {"title": {"text": "time [s]"}}}}
    pred = {"test": hostile("idtest"), "cycle": hostile("idcycle"), "amb_temp_c": 23.0,
            "fuel_measured_g": 100.0, "fuel_predicted_g": 101.0, "error_rel": 0.01, "ac_on": False}
    data = {"vehicle": hostile("idveh"), "tests": [hostile("idtest")],
            "road_load": {"values": {hostile("idcoef"): 1.0}, "ci95": {hostile("idcoef"): 0.1},
                          "template": {hostile("idcoef"): hostile("idtmpl")}, "r2": 0.99,
                          "rmse_n": 10.0, "lag_s": 0.1},
            "gears": [{"gear": hostile("idgear"), "identified": 3.0, "data_median": None,
                       "locked_samples": 10}],
            "fuel_map": {"r2": 0.9, "r2_5s": 0.95, "delay_s": 1.0, "tau_s": 0.5,
                         "idle_fuel_kg_s": 1e-4, "overrun_fuel_kg_s": 0.0, "fuel_cut_speed_rad_s": 100.0},
            "drag": {"force_n": 1.0, "force_n_per_mps": 0.1, "note": hostile("iddrag")},
            "ac": {"ac_power_w": 500.0, "test": hostile("idac"), "phases": [1], "fuel_measured_g": 1.0,
                   "fuel_model_without_ac_g": 0.9},
            "warmup": {"fraction": 0.1, "time_constant_s": 100.0, "provenance": hostile("idwarm"),
                       "note": hostile("idwnote"), "phases": [{"phase": hostile("idwphase"), "cold_g": 1.0,
                                                               "hot_g": 0.9, "fitted_excess_g": 0.1}]},
            "predictions": [pred]}
    a = write_identification_page(root / "identify.html", data, [copy.deepcopy(fig)])
    preds = [{**pred, "ac_reason": hostile("idacwhy"), "start": hostile("idstart"),
              "cold_reason": hostile("idcold"),
              "phases": [{"name": hostile("idphase"), "measured_g": 50.0, "u_g": 1.0,
                          "predicted_g": 51.0, "error_rel": 0.02}]}]
    b = write_prediction_page(root / "predict.html", hostile("idveh"), preds, [copy.deepcopy(fig)])
    return [(a, ["idveh", "idtest", "idcycle", "idcoef", "idtmpl", "idgear", "iddrag", "idac",
                 "idwarm", "idwnote", "idwphase", "idfig"]),
            (b, ["idveh", "idtest", "idcycle", "idacwhy", "idstart", "idcold", "idphase", "idfig"])]


def _batch_index(root: Path) -> tuple[Path, list[str]]:
    from vehval.report.batch_index import render_index_page

    tests = [{"test_id": hostile(f"bt{i}"), "status": hostile("bstatus") if i else "ok",
              "error": hostile("berror"), "vehicle": hostile("bveh"), "cycle": hostile("bcycle"),
              "outputs": ["report.html"], "source_run_id": "r",
              "n_findings_by_severity": json.dumps({hostile("bsev"): 2}),
              "distance_m": 1000.0 * (i + 1), "fuel_mass_kg": 0.1, "fuel_economy_mpg": 50.0 + i,
              "soc_change": 0.01 * i, "ess_energy_j": 1e5, "eng_energy_j": 1e6} for i in range(2)]
    var = [{"vehicle": hostile("bveh"), "cycle": hostile("bcycle"), "metric": hostile("bmetric"),
            "n": 2, "mean": 1.0, "std": 0.1, "cv": 0.1, "min": 0.9, "max": 1.1}]
    res = [{"vehicle": hostile("bveh"), "cycle": hostile("bcycle"), "temperature_band": hostile("bband"),
            "start": hostile("bstart"), "scope": hostile("bscope"), "kind": "phase", "n": 2,
            "mean": 50.0, "std": 1.0, "cv": 0.02, "mean_u": 1.0}]
    phases = [(hostile("bt0"), hostile("bscope"), "phase", 50.0, 1.0), (hostile("bt1"), "t", "test", 51.0, None)]
    run = {"run_id": hostile("brun"), "started": hostile("bstarted"), "vehval_version": hostile("bver"),
           "n_ok": 1, "n_failed": 1, "n_skipped": 0}
    path = root / "index.html"
    path.write_text(render_index_page(run, tests, var, res, phases), encoding="utf-8")
    return path, ["bt0", "bt1", "bstatus", "berror", "bveh", "bcycle", "bsev", "bmetric", "bband",
                  "bstart", "bscope", "brun", "bstarted", "bver"]


def _sensitivity_page(root: Path) -> tuple[Path, list[str]]:
    from vehval.report.page import plotly_asset_name, write_plotly_asset
    from vehval.report.sensitivity_page import render_sensitivity_page

    cyc = hostile("scycle")
    result = {"vehicle": hostile("sveh"), "dt_s": 1.0, "cycles": [cyc],
              "base": {cyc: {"mpg": 60.0}},
              "parameters": [{"key": hostile("sparam"), "swing_pct": 3.0,
                              "cycles": {cyc: {"low_pct": -1.0, "high_pct": 2.0}},
                              "uncertainty": {hostile("sunckey"): hostile("suncval")},
                              "source": hostile("ssource")}],
              "monte_carlo": {cyc: {"p5": 58.0, "p50": 60.0, "p95": 62.0, "n": 10}}}
    write_plotly_asset(root)
    path = root / "sensitivity.html"
    path.write_text(render_sensitivity_page(result, plotly_asset_name()), encoding="utf-8")
    return path, ["sveh", "scycle", "sparam", "ssource"]


@pytest.fixture(scope="module")
def pages(tmp_path_factory) -> dict[str, tuple[Path, list[str]]]:
    root = tmp_path_factory.mktemp("hostile")
    ident, pred = _identification_pages(root)
    return {"report": _qa_report(root), "epa": _epa_report(root), "identify": ident,
            "predict": pred, "batch-index": _batch_index(root), "sensitivity": _sensitivity_page(root)}


# ------------------------------------------------------------------------ the markup
_DATA_BLOCK = re.compile(r'<script type="application/json" id="[^"]*">(.*?)</script>', re.S)
_SCRIPT = re.compile(r"<script(?P<attrs>[^>]*)>(?P<body>.*?)</script>", re.S)
_CSP = re.compile(r'<meta http-equiv="Content-Security-Policy" content="([^"]*)">')
_EVENT_ATTR = re.compile(r"<[a-zA-Z][^<>]*\son[a-zA-Z]+\s*=", re.S)


def _visible(html: str) -> str:
    """The page without its script elements (data blocks, plotly.js, render.js)."""
    return _SCRIPT.sub("", html)


@pytest.mark.parametrize("name", ["report", "epa", "identify", "predict", "batch-index", "sensitivity"])
def test_page_shows_hostile_text_escaped(pages, name):
    path, tags = pages[name]
    html = path.read_text(encoding="utf-8")
    visible = _visible(html).lower()
    # every field is on the page, as escaped text (EPA upper-cases the originator)
    missing = [tag for tag in tags if str(escape(hostile(tag))).lower() not in visible]
    assert missing == []
    for raw in ("<svg onload", "<img", "<script>document.title", "<script>alert"):
        assert raw not in visible, raw
    assert not _EVENT_ATTR.search(visible)
    # the only scripts: data blocks (inert, no "</" inside) and the page's own, hashed
    policy = dict(d.strip().split(" ", 1) for d in
                  _CSP.search(html).group(1).replace("&#39;", "'").split(";"))
    script_src = policy["script-src"].split()
    assert "'unsafe-inline'" not in script_src and "'unsafe-eval'" not in script_src
    for m in _SCRIPT.finditer(html):
        attrs, body = m.group("attrs"), m.group("body")
        if 'type="application/json"' in attrs:
            assert "</" not in body and "<!--" not in body
        elif 'type="application/octet-stream"' in attrs:   # the compressed plotly.js: base64
            assert attrs == ' id="plotly-gz" type="application/octet-stream"'
            assert re.fullmatch(r"[A-Za-z0-9+/=]*", body)
        elif "src=" in attrs:
            assert re.fullmatch(r' id="plotly-js" src="[^"/:\\][^":\\]*"', attrs) and body == "", attrs
            assert "file:" in script_src
        else:
            assert re.fullmatch(r' id="(vv-boot|vv-render)"', attrs), attrs
            assert script_hash(body) in script_src
    # the payload's entity-encoded part is shown as typed, not decoded into a tag
    assert "&amp;#x3c;img src=x onerror=alert(2)&amp;#x3e;" in visible


# --------------------------------------------------------------------------- Chromium
@pytest.mark.slow
@pytest.mark.browser
def test_hostile_pages_in_chromium(pages):
    if not Path(CHROMIUM).exists():
        pytest.skip("chromium not installed (run `make browser`)")
    sync_api = pytest.importorskip("playwright.sync_api")
    seen: dict[str, dict] = {}
    with sync_api.sync_playwright() as p:
        try:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        except Exception as exc:  # noqa: BLE001 - a broken browser install is a skip, not a failure
            pytest.skip(f"chromium does not start: {exc}")
        for name, (path, _) in pages.items():
            page = browser.new_page(viewport={"width": 1300, "height": 900})
            state: dict = {"dialogs": [], "remote": [], "errors": []}
            page.add_init_script("window.__csp = []; document.addEventListener("
                                 "'securitypolicyviolation', e => window.__csp.push("
                                 "e.violatedDirective + ' ' + e.blockedURI));")
            page.on("dialog", lambda d, s=state: (s["dialogs"].append(d.message), d.dismiss()))
            page.on("pageerror", lambda e, s=state: s["errors"].append(str(e)))
            page.on("console", lambda m, s=state: s["errors"].append(m.text) if m.type == "error" else None)

            def route(r, s=state):
                if r.request.url.startswith(LOCAL):
                    r.continue_()
                else:
                    s["remote"].append(r.request.url)
                    r.abort()
            page.route("**/*", route)
            page.goto(path.as_uri())
            page.evaluate("window.vehvalReport ? window.vehvalReport.renderAll() : null")
            page.wait_for_timeout(300)
            state.update(page.evaluate("""() => ({
                title: document.title, csp: window.__csp,
                figs: document.querySelectorAll('.vv-fig').length,
                drawn: Array.from(document.querySelectorAll('.vv-fig')).filter(
                    el => el.querySelector('.plot-container svg.main-svg')).length,
                scripts: document.scripts.length,
                handlers: Array.from(document.querySelectorAll('*')).filter(el => Array.from(
                    el.attributes).some(a => /^on/i.test(a.name))).map(el => el.outerHTML.slice(0, 80)),
                imgs: document.querySelectorAll('img').length})"""))
            state["expected_title"] = path.read_text(encoding="utf-8").split("<title>")[1].split("</title>")[0]
            seen[name] = state
            page.close()
        browser.close()
    from html import unescape

    for name, s in seen.items():
        assert s["dialogs"] == [] and s["title"] != "pwned", (name, s)
        assert " ".join(unescape(s["expected_title"]).split()) == s["title"], name
        assert s["remote"] == [] and s["csp"] == [] and s["errors"] == [], (name, s)
        assert s["handlers"] == [] and s["imgs"] == 0, (name, s)
        assert s["figs"] == s["drawn"], (name, s)
        if name != "epa":  # the EPA report is one inline SVG, without script
            assert s["drawn"] >= 1, (name, s)
    assert seen["report"]["drawn"] >= 20
