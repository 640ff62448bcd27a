"""The workbench kept open all day (no browser): an error page answers with the API's status,
a folder of more tests than one test's file bound lists and opens every one, a vehicle file
outside the workspace is refused before it is read, and the catalog's metric headline states
the U of the figure it leads with."""

from __future__ import annotations

import html
import shutil
from pathlib import Path

import pytest
import yaml

pytest.importorskip("starlette")
pytest.importorskip("httpx2")


from vehval.serve.bench import MAX_DATA_FILES  # noqa: E402

from .helpers import client as _client  # noqa: E402


@pytest.mark.parametrize(("path", "params", "status", "words"), [
    ("/test", {"dir": "nope"}, 400, "nope: not found in the workspace"),
    ("/test", {"dir": "../x"}, 403, "path outside the workspace refused"),
    ("/test", {"dir": "virtual", "n": "3"}, 400, "bad query: n: unknown key"),
    ("/test", {"dir": "virtual", "test": "zz"}, 400, "no test 'zz'"),
    ("/catalog", {}, 400, "bad query: db: required"),
    ("/catalog", {"db": "missing.duckdb"}, 400, "missing.duckdb: not found"),
    ("/catalog", {"db": "/etc/passwd"}, 403, "path outside the workspace refused"),
])
def test_error_pages_answer_the_api_status(workspace, path, params, status, words):
    r = _client(workspace).get(path, params=params)
    assert r.status_code == status, r.text
    assert "text/html" in r.headers["content-type"] and words in html.unescape(r.text)
    assert "Traceback" not in r.text


def test_good_pages_stay_200(workspace):
    c = _client(workspace)
    assert c.get("/test", params={"dir": "virtual"}).status_code == 200


def test_folder_of_more_tests_than_the_file_bound_lists_and_opens_each(workspace):
    """A batch folder (one template, one file per test) of MAX_DATA_FILES + 6 tests: every
    test listed and opened, none left out as 'too many files' (that bound is one test's)."""
    d = workspace / "virtual"
    n = MAX_DATA_FILES + 6
    for i in range(n):
        shutil.copy(d / "run_d3.txt", d / f"t{i:03d}_d3.txt")
    (d / "run_d3.txt").unlink()
    data = yaml.safe_load((d / "template.yaml").read_text(encoding="utf-8"))
    data["files"][0]["match"] = "*_d3.txt"
    (d / "template.yaml").write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    c = _client(workspace)
    home = c.get("/").text
    assert all(f"test=t{i:03d}_d3" in home for i in range(n))
    assert "more data files" not in home
    last = f"t{n - 1:03d}_d3"
    r = c.get("/api/test", params={"dir": "virtual", "test": last})
    assert r.status_code == 200, r.text
    assert [f["file"] for f in r.json()["files"]] == [f"{last}.txt"]
    assert f"{n} tests under one template" in c.get("/test", params={"dir": "virtual"}).text


@pytest.fixture()
def outside_car(tmp_path) -> Path:
    """A YAML file outside the workspace whose content must never show."""
    p = tmp_path / "outside" / "car.yaml"
    p.parent.mkdir()
    p.write_text("SECRET_VEHICLE_KEY: 1\nbody: {SECRET_BODY_KEY: 2}\n", encoding="utf-8")
    return p


@pytest.mark.parametrize("name", ["ABS", "../outside/car.yaml", "/nowhere/car.yaml"])
def test_vehicle_file_outside_the_workspace_is_refused_unread(workspace, outside_car, name,
                                                             monkeypatch):
    monkeypatch.chdir(workspace)   # relative vehicle files are named from here, as the CLI does
    name = str(outside_car) if name == "ABS" else ("../" + name if name.startswith("..")
                                                    else name)
    tpl = workspace / "virtual" / "template.yaml"
    before = tpl.read_text(encoding="utf-8")
    r = _client(workspace).post("/api/template", params={"dir": "virtual"},
                                json={"vehicle": name})
    assert r.status_code == 403, r.text
    msg = r.json()["error"]
    assert "outside the workspace" in msg and "SECRET" not in msg
    assert tpl.read_text(encoding="utf-8") == before


def test_template_naming_a_vehicle_outside_is_refused_on_run_and_model(workspace, outside_car):
    tpl = workspace / "virtual" / "template.yaml"
    data = yaml.safe_load(tpl.read_text(encoding="utf-8"))
    data["vehicle"] = str(outside_car)
    tpl.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    c = _client(workspace)
    for r in (c.post("/api/run", params={"dir": "virtual"}, json={}),
              c.get("/api/model", params={"dir": "virtual"}),
              c.post("/api/model", params={"dir": "virtual"}, json={})):
        assert r.status_code == 403, r.text
        assert "outside the workspace" in r.json()["error"] and "SECRET" not in r.text
    # the server goes on: a shipped vehicle name is fine
    data["vehicle"] = "prius_2004"
    tpl.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    assert c.get("/api/model", params={"dir": "virtual"}).status_code == 200


@pytest.mark.parametrize(("units", "text"), [
    ("metric", "wltc3b: 5.72 ± 0.07 L/100 km (41.14 ± 0.50 mpg)"),
    ("us", "wltc3b: 41.14 ± 0.50 mpg (5.72 ± 0.07 L/100 km)"),
])
def test_catalog_headline_states_the_u_of_both_figures(monkeypatch, units, text):
    """The catalog keeps U of mpg only; L/100 km (the metric headline's first figure) has the
    same relative U, stated as the test's page states it."""
    from vehval.serve.catalog_view import view

    monkeypatch.setenv("VEHVAL_UNITS", units)
    row = {"headline_name": "wltc3b", "headline_mpg": 41.1416, "headline_u_mpg": 0.4988,
           "headline_l_per_100km": 5.71721}
    _, cells = view([row])
    assert cells[0]["headline"] == text
