"""Structure of the self-contained HTML report: one plotly.js, every table, nothing fetched."""

from __future__ import annotations

import base64
import json
import re

import numpy as np
import pytest

from vehval.report import build_reports, write_report

from .helpers import make_control, make_qa, make_test, make_validation

TABLE_KEYS = ("findings", "table2", "table3", "alignment", "alignment-pairs", "selection-kept",
              "selection-dropped", "calculations", "mapping", "deleted")


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    path = tmp_path_factory.mktemp("rep") / "report.html"
    control = {"tables": [{"title": "Engine on/off thresholds", "columns": ["threshold", "value [W]"],
                           "rows": [["power on", 9000.0], ["power off", 5000.0]]}],
               "figures": [{"title": "Engine on map", "figure": {"data": [{"type": "bar", "x": [1, 2], "y": [3, 4]}],
                                                                 "layout": {}}}]}
    validation = {"tables": [{"title": "Fuel economy", "rows": [{"quantity": "fuel [kg]", "test": 0.5,
                                                                  "simu": 0.52}]}],
                  "figures": [], "metrics": {"soc_final_error": 0.01}}
    write_report(path, test=make_test(), qa=make_qa(), control=control, validation=validation)
    return path.read_text(encoding="utf-8")


def _strip_plotly(text: str) -> str:
    return re.sub(r'<script id="plotly-gz" type="application/octet-stream">.*?</script>', "",
                  text, count=1, flags=re.S)


def test_plotly_embedded_once(report):
    """plotly.js is embedded once, gzip + base64, and unpacks to exactly the hashed source."""
    import base64
    import gzip

    from plotly.offline import get_plotlyjs

    from vehval.report.safety import script_hash
    blocks = re.findall(r'<script id="plotly-gz" type="application/octet-stream">(.*?)</script>',
                        report, flags=re.S)
    assert len(blocks) == 1 and report.count('<script id="vv-boot">') == 1
    js = gzip.decompress(base64.b64decode(blocks[0])).decode("utf-8")
    assert js == get_plotlyjs().replace("</script", "<\\/script")
    assert script_hash(js) in report.replace("&#39;", "'")     # listed in the page's policy
    assert get_plotlyjs()[:200] not in report                     # not also in clear text
    # figures are JSON data blocks, not copies of the library; the library is compressed
    assert len(blocks[0]) < 0.5 * len(js)
    assert len(report) < len(blocks[0]) + 3_000_000


def test_every_table_present(report):
    for key in TABLE_KEYS:
        assert f'data-table="{key}"' in report, key
    for key in ("control-", "validation-"):
        assert f'data-table="{key}' in report
    for sec in ("summary", "import", "alignment", "qa1", "qa2", "qa3", "calc", "selection", "signals",
                "engineering", "control", "validation"):
        assert f'<section id="{sec}"' in report, sec


def test_no_network_reference(report):
    own = _strip_plotly(report)
    assert not re.search(r'(src|href)\s*=\s*["\']?\s*(https?:)?//', own, re.I)
    assert "fetch(" not in own and "XMLHttpRequest" not in own and "@import" not in own
    assert "url(http" not in own


def test_figures_are_valid_json_with_data(report):
    blocks = re.findall(r'<script type="application/json" id="(fig-[^"]+)-data">(.*?)</script>', report, re.S)
    assert len(blocks) >= 10
    for key, text in blocks:
        fig = json.loads(text)
        assert fig["data"], key
        assert "template" not in fig["layout"]            # one shared template for the page
        assert f'id="{key}"' in report


def test_virtual_banner_only_when_synthetic(tmp_path):
    p = tmp_path / "r.html"
    write_report(p, test=make_test(synthetic=False), qa=None)
    text = p.read_text(encoding="utf-8")
    assert 'id="virtual-banner"' not in text
    assert "No QA result" in text
    write_report(p, test=make_test(synthetic=True), qa=None)
    assert 'id="virtual-banner"' in p.read_text(encoding="utf-8")


def test_import_mapping_and_finding_rows(report):
    # raw name and unit -> standard name and unit, deleted channel with its reason
    # standard name, SI unit stored, unit shown, source, raw name, declared (raw) unit
    assert re.search(r"<td>veh_spd_test</td><td>m/s</td><td>mph</td><td>dyno</td>"
                     r"<td>Dyno_Speed</td><td>mph</td>", report)
    assert "Test_Cell_RH" in report and "not used" in report
    assert report.count('class="sev-error"') == 1 and report.count('class="sev-warning"') == 2


def test_engineering_notes_without_vehicle(report):
    assert "component-map plots are skipped" in report
    assert "Willans line" in report and "Energy flow" in report


def test_failed_run_leaves_nothing(tmp_path, monkeypatch):
    def boom(*a, **k):
        raise RuntimeError("figure failed")
    import vehval.report.figures as figures_mod

    monkeypatch.setattr(figures_mod, "figure_json", boom)
    with pytest.raises(RuntimeError):
        build_reports(tmp_path / "out", make_test(), make_qa())
    assert not list((tmp_path).rglob("*.html")) and not list(tmp_path.rglob("*.xlsx"))
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]


def test_failed_excel_leaves_no_html(tmp_path, monkeypatch):
    import vehval.report as rep

    def boom(*a, **k):
        raise OSError("disk full")
    monkeypatch.setattr(rep, "write_tables", boom)
    with pytest.raises(OSError):
        build_reports(tmp_path / "out", make_test(), make_qa())
    assert not [p for p in tmp_path.rglob("*") if p.is_file()]


def test_control_json_uses_its_report_entry():
    from vehval.report.plugins import control_section

    doc = make_control()
    sec = control_section(doc)
    titles = [t.title for t in sec.tables]
    # exactly the analysis' own report tables: the raw arrays (timeline, bins...) are not dumped
    assert titles == [t["title"] for t in doc["report"]["tables"]]
    captions = [f.title for f in sec.figures]
    assert "Operating modes over time" in captions
    assert len(sec.figures) >= len(doc["report"]["figures"]) + 1
    facts = dict(sec.facts)
    assert facts["Test"] == "T-report"
    timeline = next(f for f in sec.figures if f.title == "Operating modes over time")
    # one bar per timeline segment, starting where the segment starts [s]
    bars = timeline.figure["data"]
    assert sum(len(b["base"]) for b in bars) == len(doc["modes"]["timeline"])
    assert timeline.linked


def test_validation_payload_figures_are_svg_and_linked():
    from vehval.report.plugins import validation_section

    payload = make_validation()
    sec = validation_section(payload)
    assert [t.title for t in sec.tables] == [t["title"] for t in payload["tables"]]
    assert len(sec.figures) == len(payload["figures"])
    for f in sec.figures:
        assert {t["type"] for t in f.figure["data"]} <= {"scatter", "bar"}   # no WebGL contexts
        assert "title" not in f.figure["layout"] or f.figure["layout"]["title"] != f.title
        assert f.linked                                                      # x axes are time [s]


def test_normalise_figure_rules():
    from vehval.report.figures import MAX_SVG_POINTS, figure_json
    from vehval.report.plugins import normalise_figure

    small = {"data": [{"type": "scattergl", "x": [0, 1], "y": [1, 2]}], "layout": {"title": "A"}}
    fig, cap = normalise_figure(small)
    assert cap == "A" and "title" not in fig["layout"] and fig["data"][0]["type"] == "scatter"
    assert small["data"][0]["type"] == "scattergl"                           # input not modified
    n = 3 * MAX_SVG_POINTS
    big = {"data": [{"type": "scattergl", "mode": "lines", "x": np.arange(n) * 0.1,
                     "y": np.sin(np.arange(n) / 50.0)}], "layout": {"title": {"text": "B"}}}
    fig, cap = normalise_figure(big, "other caption")
    assert cap == "other caption" and fig["layout"]["title"] == {"text": "B"}
    # WebGL traces need eval (regl): drawn as SVG, a long one thinned keeping its extremes
    assert fig["data"][0]["type"] == "scatter"
    trace = json.loads(figure_json(fig))["data"][0]
    y = np.frombuffer(base64.b64decode(trace["y"]["bdata"]), dtype=np.float32)
    assert trace["type"] == "scatter" and y.size <= MAX_SVG_POINTS
    assert y.max() == pytest.approx(1.0, abs=1e-4) and y.min() == pytest.approx(-1.0, abs=1e-4)
    markers = {"data": [{"type": "scattergl", "mode": "markers", "x": list(range(n)),
                         "y": list(range(n)), "text": [str(i) for i in range(n)]}]}
    trace = json.loads(figure_json(markers))["data"][0]
    assert trace["type"] == "scatter" and len(trace["text"]) == MAX_SVG_POINTS
    assert trace["text"][1] == "3"                                           # even stride


def test_raw_test_plots_dropped_signals_aligned():
    from vehval.report.html import build_sections

    test, raw = make_test(), make_test()
    # the validated test lost the OBD speed (dropped by selection); the raw one has it on the
    # OBD clock, 1.2 s early: the QA applied +1.2 s
    test.signals.pop("veh_spd_obd_test")
    raw["veh_spd_obd_test"].time = raw["veh_spd_obd_test"].time - 1.2
    qa = make_qa()
    without = {s.key: s for s in build_sections(test, qa)}
    assert not without["qa2"].figures
    secs = {s.key: s for s in build_sections(test, qa, raw=raw)}
    assert [f.title for f in secs["qa2"].figures] == ["veh_spd_obd_test vs veh_spd_test"]
    x = secs["qa2"].figures[0].figure["data"][0]["x"]
    y = secs["qa2"].figures[0].figure["data"][0]["y"]
    # after the shift the OBD samples sit on the dyno trace again: y = x + 0.1 m/s (atol: the
    # 1 Hz samples are compared with the 10 Hz trace interpolated at the same instants); the
    # scatter is drawn in the display unit (mph or km/h)
    from vehval.display import unit_for

    k = unit_for("m/s").factor
    np.testing.assert_allclose(y, x + 0.1 * k, atol=0.02 * k)
    assert all("veh_spd_obd_test" not in n for f in secs["signals"].figures
               for n in [t["name"] for t in f.figure["data"]])                # only QA sections


def test_string_titles_become_objects():
    """plotly.js 3 ignores ``title: "text"``: axis titles of payload figures must survive."""
    from vehval.report.plugins import normalise_figure

    fig, _ = normalise_figure({"data": [{"type": "bar", "x": [1], "y": [2], "marker": {"colorbar": {"title": "c"}}}],
                               "layout": {"title": "T", "xaxis": {"title": "power [kW]"},
                                          "yaxis2": {"title": {"text": "n"}}}})
    assert fig["layout"]["xaxis"]["title"] == {"text": "power [kW]"}
    assert fig["layout"]["yaxis2"]["title"] == {"text": "n"}
    assert fig["data"][0]["marker"]["colorbar"]["title"] == {"text": "c"}


def test_shared_plotly_asset(tmp_path):
    """``plotly_js=<relative path>``: the report references one shared local copy."""
    from vehval.errors import ConfigError
    from vehval.report import plotly_asset_name, write_plotly_asset

    asset = write_plotly_asset(tmp_path / "assets")
    assert asset.name == plotly_asset_name() and asset.stat().st_size > 3e6
    before = asset.stat().st_mtime_ns
    assert write_plotly_asset(tmp_path / "assets").stat().st_mtime_ns == before  # unchanged: kept
    asset.write_text("stale", encoding="utf-8")
    assert write_plotly_asset(tmp_path / "assets").stat().st_size > 3e6         # different: rewritten
    rel = f"../assets/{asset.name}"
    path = write_report(tmp_path / "rep" / "report.html", test=make_test(), qa=make_qa(), plotly_js=rel)
    text = path.read_text(encoding="utf-8")
    assert f'<script id="plotly-js" src="{rel}"></script>' in text and "* plotly.js v" not in text
    assert path.stat().st_size < 1e6 and (path.parent / rel).resolve() == asset.resolve()
    for bad in ("https://cdn.plot.ly/plotly.min.js", "//cdn/x.js", "/abs/plotly.js", "C:\\p.js", ""):
        with pytest.raises(ConfigError, match="relative path"):
            write_report(tmp_path / "bad.html", test=make_test(), plotly_js=bad)
    assert not (tmp_path / "bad.html").exists()


def test_long_numeric_lists_are_sent_as_typed_arrays_short_and_text_lists_as_json():
    from vehval.report.figures import TYPED_MIN_LEN, figure_json

    n = 2 * TYPED_MIN_LEN
    y = [float(i) for i in range(n)]
    y[5] = None                                        # a gap stays a gap (NaN)
    fig = {"data": [{"type": "scatter", "x": list(range(n)), "y": y},
                    {"type": "bar", "x": ["a", "b"] * TYPED_MIN_LEN, "y": [1, 2] * TYPED_MIN_LEN},
                    {"type": "scatter", "x": [0, 1, 2], "y": [3, 4, 5]}]}
    d = json.loads(figure_json(fig))["data"]
    yy = np.frombuffer(base64.b64decode(d[0]["y"]["bdata"]), dtype=np.float32)
    assert d[0]["x"]["dtype"] in ("f4", "f8") and yy.size == n and np.isnan(yy[5])
    assert yy[6] == 6.0
    assert d[1]["x"][:2] == ["a", "b"] and isinstance(d[1]["y"], dict)   # categories stay text
    assert d[2]["x"] == [0, 1, 2]                                        # short: plain JSON


def test_import_mapping_names_declared_stored_and_shown_units(monkeypatch):
    """A channel declared in % or kPa reads 'dimensionless' or 'Pa' as its stored SI unit:
    the mapping names the declared (raw) unit, the SI unit stored and the unit shown."""
    from vehval.report.sections import import_section
    from vehval.test import Signal, Test, TestMeta

    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    t = np.arange(0.0, 10.0, 1.0)
    sigs = [Signal.standard("ess_soc_test", t, np.full(t.size, 0.55), source="obd",
                            raw_name="SOC", raw_unit="%"),
            Signal.standard("eng_pres_intake_test", t, np.full(t.size, 4.0e4), source="obd",
                            raw_name="MAP", raw_unit="kPa"),
            Signal.standard("veh_spd_test", t, np.full(t.size, 10.0), source="obd",
                            raw_name="VSS", raw_unit="mph")]
    table = import_section(Test(sigs, TestMeta(test_id="T"))).tables[0]
    rows = {r[0]: dict(zip(table.columns, r)) for r in table.rows}
    want = {"ess_soc_test": ("dimensionless", "%", "%"),
            "eng_pres_intake_test": ("Pa", "kPa", "kPa"),
            "veh_spd_test": ("m/s", "km/h", "mph")}
    for name, (si, shown, raw) in want.items():
        assert (rows[name]["unit (SI)"], rows[name]["shown as"], rows[name]["raw unit"]) == \
            (si, shown, raw), name
