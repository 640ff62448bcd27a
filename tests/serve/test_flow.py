"""The lab flow through the workbench's API (no browser): a folder of many tests under one
template, the report of a test, the car's constants edited with the command line's checks,
the user's drops counted, the wrong-token page."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from starlette.testclient import TestClient  # noqa: E402

from vehval.serve.app import create_app  # noqa: E402

from .helpers import client as _client  # noqa: E402


@pytest.fixture()
def many(workspace) -> Path:
    """``WS/virtual/`` holding two tests (one D3 file each) under one one-entry template."""
    d = workspace / "virtual"
    shutil.copy(d / "run_d3.txt", d / "second_d3.txt")
    data = yaml.safe_load((d / "template.yaml").read_text(encoding="utf-8"))
    data["files"][0]["match"] = "*_d3.txt"
    data["fuel"] = "gasoline_e0"
    (d / "template.yaml").write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return workspace


def test_folder_of_many_tests_opens_as_one_test_per_file(many):
    c = _client(many)
    home = c.get("/").text
    assert "test=run_d3" in home and "test=second_d3" in home
    # the folder itself is not one test: the page says to open one of its tests
    page = c.get("/test", params={"dir": "virtual"}).text
    assert "2 tests under one template" in page
    m = c.post("/api/run", params={"dir": "virtual", "test": "second_d3"}, json={}).json()
    assert m["error"] is None, m["error"]
    assert [f["file"] for f in m["files"]] == ["second_d3.txt"]
    assert (many / "virtual" / "qa" / "second_d3" / "findings.json").is_file()
    # the figure of one of that test's findings (the test named, as every query takes it)
    if m["findings"]:
        r = c.get("/api/finding", params={"dir": "virtual", "test": "second_d3", "i": 0})
        assert r.status_code == 200, r.text
        assert r.json()["figure"]["data"]
    r = c.get("/api/test", params={"dir": "virtual", "test": "nope"})
    assert r.status_code == 400 and "no test 'nope'" in r.json()["error"]
    # the report of that test, built from the page and served from the workspace
    r = c.post("/api/report", params={"dir": "virtual", "test": "second_d3"}, json={})
    assert r.status_code == 200, r.text
    assert r.json()["report"] == "virtual/qa/second_d3/report.html"
    page = c.get("/files/virtual/qa/second_d3/report.html")
    assert page.status_code == 200 and "<html" in page.text[:2000].lower()


def test_car_edits_checked_and_formats_kept(workspace):
    c = _client(workspace)
    path = workspace / "virtual" / "template.yaml"
    path.write_text(path.read_text(encoding="utf-8")
                    + "constants:\n  test_mass_kg: 1727   # test weight\n", encoding="utf-8")
    q = {"dir": "virtual"}
    r = c.post("/api/template", params=q, json={"constants": {"test_mass_kg": -5}})
    assert r.status_code == 400 and "\n" not in r.json()["error"]
    assert "test_mass_kg" in r.json()["error"]
    r = c.post("/api/template", params=q, json={"vehicle": "no_such_car_anywhere"})
    assert r.status_code == 400 and "vehicle" in r.json()["error"]
    r = c.post("/api/template", params=q, json={"constants": {"road_load_a_n": "x"}})
    assert r.status_code == 400
    r = c.post("/api/template", params=q, json={
        "vehicle": "prius_2004", "vehicle_name": "Prius on roll 2", "fuel": "gasoline_e0",
        "constants": {"road_load_a_n": 120.5}})
    assert r.status_code == 200, r.text
    m = r.json()
    assert m["vehicle"] == "prius_2004" and m["constants"]["road_load_a_n"] == 120.5
    text = path.read_text(encoding="utf-8")
    assert "  test_mass_kg: 1727   # test weight" in text        # literal and comment kept
    assert "vehicle_name: Prius on roll 2" in text
    assert "# fuel:" not in text                                # no stale placeholder


def test_user_drop_counted(workspace):
    c = _client(workspace)
    q = {"dir": "virtual"}
    c.post("/api/template", params=q, json={"fuel": "gasoline_e0"})
    before = c.get("/api/test", params=q).json()["summary"]["dropped"]
    m = c.post("/api/selection", params=q,
               json={"signal": "dyno_frc_test", "action": "drop", "reason": "drifting"}).json()
    assert "dyno_frc_test" in m["selection"]["dropped"]
    assert m["summary"]["dropped"] == len(m["selection"]["dropped"]) >= before + 1


def test_wrong_token_answers_a_page_for_a_browser_and_json_for_the_api(workspace):
    c = TestClient(create_app(workspace), base_url="http://127.0.0.1")
    r = c.get("/?token=wrong", headers={"Accept": "text/html,application/xhtml+xml"})
    assert r.status_code == 403 and r.headers["content-type"].startswith("text/html")
    assert "vehval serve" in r.text and "wrong token" in r.text
    r = c.get("/api/test?token=wrong", headers={"Accept": "text/html"})
    assert r.status_code == 403 and r.json()["error"].startswith("wrong token")
    r = c.get("/", headers={"Accept": "application/json"})
    assert r.status_code == 403 and "token required" in r.json()["error"]


def test_unitless_csv_review(tmp_path):
    """An OBD log without units: no "high" with a blank unit, the command line's "to do"
    lines, and every missing unit named by one save."""
    d = tmp_path / "ws" / "obd"
    d.mkdir(parents=True)
    rows = "\n".join(f"{i},{20 + i % 7},{800 + 10 * i},{25 + i % 3},{12.0 + 0.01 * i}"
                     for i in range(200))
    (d / "log.csv").write_text("t_idx,eng2vsp,RPM,bt1,Bty_Curr\n" + rows + "\n", encoding="utf-8")
    c = _client(tmp_path / "ws")
    m = c.get("/api/test", params={"dir": "obd"}).json()
    chans = {ch["raw"]: ch for ch in m["files"][0]["channels"]}
    for ch in chans.values():
        assert not (ch["confidence"] == "high" and not (ch["unit"] or ch["header_unit"])), ch
    assert chans["eng2vsp"]["confidence"] == "unit missing"
    assert any("eng2vsp" in t for t in m["todo"]) and all(t.startswith("to do: ") for t in m["todo"])
    r = c.post("/api/template", params={"dir": "obd"}, json={"fuel": "gasoline_e0"}).json()
    err = r["error"] or ""
    for raw in ("eng2vsp", "bt1", "Bty_Curr"):
        assert f"'{raw}'" in err, err
