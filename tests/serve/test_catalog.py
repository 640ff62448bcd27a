"""The catalog browser's API on a real `vehval batch` output of two virtual tests."""

from __future__ import annotations

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx")
from starlette.testclient import TestClient  # noqa: E402

from vehval.catalog import open_catalog  # noqa: E402
from vehval.serve.app import create_app  # noqa: E402


def _client(ws):
    app = create_app(ws)
    wb = app.state.workbench
    return TestClient(app, base_url="http://127.0.0.1", headers={"X-Vehval-Token": wb.token})


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
