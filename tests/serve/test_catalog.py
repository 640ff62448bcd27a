"""The catalog browser's API on a real `vehval batch` output of two virtual tests."""

from __future__ import annotations

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from vehval.catalog import open_catalog  # noqa: E402

from .helpers import client  # noqa: E402


def _client(ws):
    return client(ws, csrf=False)


def test_rows_filters_and_overlay_match_the_catalog(batch_ws):
    c = _client(batch_ws)
    home = c.get("/").text
    assert "out/catalog.duckdb" in home
    r = c.get("/api/catalog", params={"db": "out/catalog.duckdb"}).json()
    assert "error" not in r, r
    with open_catalog(batch_ws / "out" / "catalog.duckdb", read_only=True) as cat:
        _, rows = cat.query("SELECT test_id, cycle, fuel_economy_mpg, distance_m FROM latest_tests "
                            "ORDER BY test_id")
    assert [(x["test_id"], x["cycle"], x["fuel_economy_mpg"], x["distance_m"]) for x in r["rows"]] \
        == [tuple(row) for row in rows]  # the catalog's numbers, exactly
    assert sorted(r["options"]["cycle"]) == ["japan1015", "udds"]
    only = c.get("/api/catalog", params={"db": "out/catalog.duckdb", "cycle": "japan1015"}).json()
    assert [x["test_id"] for x in only["rows"]] == ["japan1015"]
    rep = only["rows"][0]["report"]
    assert rep == "out/tests/japan1015/report.html"
    page = c.get(f"/files/{rep}")
    assert page.status_code == 200 and "'self'" in page.headers["content-security-policy"]
    for q in ("speed", "fuel", "engine", "soc"):
        tr = c.get("/api/catalog/trace", params={"db": "out/catalog.duckdb", "test": "udds",
                                                 "q": q, "n": 1000}).json()
        assert "error" not in tr, tr
        assert len(tr["t"]) <= 1000 and tr["span"][1] > 1300  # UDDS: 1369 s
    ph = c.get("/api/catalog/trace", params={"db": "out/catalog.duckdb", "test": "udds",
                                             "q": "speed", "axis": "phase"}).json()
    assert [p["phase"] for p in ph["phases"]] == [1, 2]  # UDDS bags 1 and 2
    assert all(p["t"][0] == 0.0 for p in ph["phases"])
    assert ph["phases"][0]["span"][1] == pytest.approx(505.0, abs=1.0)  # bag 1: 505 s
    bad = c.get("/api/catalog", params={"db": "../x.duckdb"})
    assert bad.status_code == 403


def test_overlay_from_the_batch_kept_signals_and_a_missing_soc(batch_ws, tmp_path):
    """The overlay reads the validated signals the batch kept (tests/ID/overlay.parquet): it
    works with the raw files outside the workspace; a test without an SOC signal (a
    conventional car) is named beside the plot, the others drawn, in display units."""
    import shutil

    from vehval.io.parquet import read_test, write_test
    from vehval.serve.catalog_view import overlay_figure, test_traces
    from vehval.test import Test

    ws = tmp_path / "ws"
    shutil.copytree(batch_ws / "out", ws / "out")      # the raw files stay outside `ws`
    db = (ws / "out" / "catalog.duckdb").resolve()
    root = ws.resolve()
    tr = test_traces(root, db, "udds", "speed", 1000)
    assert tr["unit"] == "mph" and tr["span"][1] > 1300
    kept = ws / "out" / "tests" / "udds" / "overlay.parquet"
    t = read_test(kept)
    write_test(Test([s for s in t if s.base != "ess_soc"], meta=t.meta), kept)
    out = overlay_figure(root, db, ["udds", "japan1015"], "soc", 1000)
    assert out["traces"] == 1 and out["missing"] == [
        "udds: no battery SOC signal in the test (a conventional car has no traction battery)"]
    assert out["figure"]["layout"]["yaxis"]["title"]["text"] == "battery SOC [%]"
    # a test the catalog holds no signals nor raw files of (a failed test): named, the rest
    # drawn (the whole overlay answered 400)
    import duckdb

    con = duckdb.connect(str(db))
    con.execute("UPDATE tests SET files = NULL WHERE test_id = 'japan1015'")
    con.close()
    (ws / "out" / "tests" / "japan1015" / "overlay.parquet").unlink()
    out = overlay_figure(root, db, ["udds", "japan1015"], "speed", 1000)
    assert out["traces"] == 1 and out["missing"] == [
        "japan1015: the catalog records no raw files or template: not overlaid"]


def test_catalog_view_is_in_display_units(batch_ws):
    c = _client(batch_ws)
    r = c.get("/api/catalog", params={"db": "out/catalog.duckdb"}).json()
    heads = [h["label"] for h in r["view"]["columns"]]
    assert "distance [mi]" in heads and "headline (U, k = 2)" in heads
    udds = r["view"]["rows"][[x["test_id"] for x in r["rows"]].index("udds")]
    row = next(x for x in r["rows"] if x["test_id"] == "udds")
    assert udds["distance_m"] == f"{row['distance_m'] / 1609.344:,.2f}"
    assert udds["headline"].startswith("udds: ") and " ± " in udds["headline"]
    ov = c.get("/api/catalog/overlay", params={"db": "out/catalog.duckdb",
                                               "tests": "udds,japan1015", "q": "soc"}).json()
    assert ov["traces"] == 2 and ov["missing"] == []


def test_headline_column_shows_each_kind_with_its_own_figures(batch_ws, bev_ws, tmp_path,
                                                             monkeypatch):
    """A battery-electric row: MPGe and kWh per distance with U (SAE J1634); a hybrid row:
    its fuel economy and the battery's share of the fuel energy (SAE J1711 NEC ratio)."""
    import json
    import shutil

    from vehval.batch import run_batch

    monkeypatch.setenv("VEHVAL_UNITS", "us")
    monkeypatch.chdir(bev_ws)   # the template names its vehicle file from there
    ws = tmp_path / "ws"
    shutil.copytree(bev_ws / "bev", ws / "in" / "bev", ignore=shutil.ignore_patterns("qa"))
    (ws / "in" / "bev" / "template.yaml").rename(ws / "template.yaml")
    run_batch(ws / "in", ws / "template.yaml", ws / "out", steps=["qa"], workers=0,
              progress=False)
    key = json.loads((bev_ws / "truth.json").read_text(encoding="utf-8"))["test"]
    r = _client(ws).get("/api/catalog", params={"db": "out/catalog.duckdb"}).json()
    row, cell = r["rows"][0], r["view"]["rows"][0]["headline"]
    assert row["headline_mpg"] is None and row["headline_j1634_scope"] == "test"
    assert row["headline_mpge"] == pytest.approx(key["mpge"], rel=0.005)
    assert row["headline_kwh_per_100km"] == pytest.approx(key["ac_kwh_per_100km"], rel=0.005)
    assert row["headline_u_mpge"] > 0 and row["headline_battery_share"] is None
    assert cell.startswith(f"whole test: {row['headline_mpge']:.1f} ± ") and "MPGe" in cell
    assert "kWh/100 mi" in cell and "mpg " not in cell + " "
    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    metric = _client(ws).get("/api/catalog", params={"db": "out/catalog.duckdb"}).json()
    assert metric["view"]["rows"][0]["headline"].split(" (")[0].endswith("kWh/100 km")
    # the hybrid keeps its fuel economy, with the battery's share of the fuel energy
    monkeypatch.setenv("VEHVAL_UNITS", "us")
    hyb = _client(batch_ws).get("/api/catalog", params={"db": "out/catalog.duckdb"}).json()
    udds, cells = next((x, v) for x, v in zip(hyb["rows"], hyb["view"]["rows"])
                       if x["test_id"] == "udds")
    assert udds["headline_mpg"] is not None and udds["headline_mpge"] is None
    assert " mpg" in cells["headline"] and "MPGe" not in cells["headline"]
    share = udds["headline_battery_share"]
    assert share is not None and cells["headline_battery_share"] == f"{100 * share:,.2f}"
    assert {"key": "headline_battery_share", "label": "battery share [%]"} in hyb["view"]["columns"]
    assert r["view"]["rows"][0]["headline_battery_share"] == ""   # none for a BEV
