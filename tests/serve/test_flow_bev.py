"""A battery-electric test in the workbench: the headline in SAE J1634 terms (MPGe and kWh
per distance with U, no fuel economy), model and test through the stage registry's validate
(traces on one linked time axis in display units, the DC energy and J1634 tables with En),
and the report from the page."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")


from .helpers import client as _client  # noqa: E402


def test_bev_headline_model_and_report(bev_ws, monkeypatch):
    from vehval.report.finding_figures import panel_units

    monkeypatch.setenv("VEHVAL_UNITS", "us")
    monkeypatch.chdir(bev_ws)   # the template names its vehicle file from there
    key = json.loads((bev_ws / "truth.json").read_text(encoding="utf-8"))["test"]
    c = _client(bev_ws)
    q = {"dir": "bev"}
    assert c.post("/api/run", params=q, json={}).status_code == 200
    h = c.get("/api/test", params=q).json()["headline"]
    assert h["kind"] == "headline" and h["fuel_economy_mpg"] is None
    e = h["electric"]
    assert e["mpge"] == pytest.approx(key["mpge"], rel=0.005)           # the answer key
    assert e["u_mpge"] > 0 and e["u_kwh_per_100mi"] > 0                  # U from the DC energy
    assert h["figure"].startswith(f"{e['mpge']:.1f} ± {e['u_mpge']:.1f} MPGe (")
    assert "kWh/100 mi" in h["figure"] and "mpg " not in h["figure"] + " "
    assert "SAE J1634" in h["rule"] and not h["j1711"]                   # no J1711 on a BEV
    assert not any("J1711" in x for x in h["caveats"])
    # model and test: the registry's validate of a battery-electric car
    m = c.get("/api/model", params=q).json()
    assert m["architecture"] == "battery_electric" and m["result"] is None
    r = c.post("/api/model", params=q, json={})
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["vehicle"] == "test_bev"
    assert [t["base"] for t in out["traces"]] == ["veh_spd", "ess_curr", "ess_volt"]
    assert [t["unit"] for t in out["traces"]] == ["mph", "A", "V"]       # display units
    assert [t["title"].split(",")[0] for t in out["tables"]] == [
        "Traces", "DC battery energy", "SAE J1634 figures"]
    assert out["tables"][0]["rows"][0][0] == "vehicle speed [mph]"      # the user's unit
    energy = out["tables"][1]
    assert "En" in energy["columns"] and energy["rows"][-1][0] == "test"
    units = panel_units(out["figure"])
    assert [next(iter(u)) for u in units.values()] == ["mph", "A", "V"]
    assert all(len(u) == 1 for u in units.values())
    assert all(out["figure"]["layout"][f"xaxis{i}"].get("matches") == "x" for i in (2, 3))
    ne = out["normalised_error"]
    assert ne["quantity"] == "DC energy" and abs(ne["en"]) <= 1 and ne["verdict"] == "consistent"
    h = c.get("/api/test", params=q).json()["headline"]
    assert "DC energy" in h["verdict"] and f"En = {ne['en']:+.2f}" in h["verdict"]
    # the report from the page, in J1634 terms
    r = c.post("/api/report", params=q, json={})
    assert r.status_code == 200, r.text
    html = c.get("/files/" + r.json()["report"]).text
    assert "MPGe" in html and "SAE J1634" in html


def test_bev_headline_in_metric_units(bev_ws, monkeypatch):
    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    monkeypatch.chdir(bev_ws)
    c = _client(bev_ws)
    q = {"dir": "bev"}
    assert c.post("/api/run", params=q, json={}).status_code == 200
    h = c.get("/api/test", params=q).json()["headline"]
    assert h["figure"].split(" (")[0].endswith("kWh/100 km") and "MPGe)" in h["figure"]
