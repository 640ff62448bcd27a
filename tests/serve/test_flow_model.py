"""Model and test of a conventional car through the API: the vehicle named before the run,
the result kept on disk until an input changes; the labels of a fuel difference beside QA
findings on the meter, and the masking of samples QA flagged."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

pytest.importorskip("starlette")
pytest.importorskip("httpx2")


from vehval.cli import main  # noqa: E402
from vehval.serve import flow  # noqa: E402

from .helpers import client as _client  # noqa: E402


@pytest.fixture(scope="module")
def car_ws(tmp_path_factory) -> Path:
    """``WS/car/``: a virtual Cruze UDDS and its template naming ``cruze_diesel_2014``."""
    ws = tmp_path_factory.mktemp("carws")
    d = ws / "car"
    assert main(["synth", "--vehicle", "cruze_diesel_2014", "--cycle", "udds", "--seed", "3",
                 "--faults", "none", "-o", str(d)]) == 0
    for name in ("README.txt", "truth.json"):
        (d / name).unlink(missing_ok=True)
    data = yaml.safe_load((d / "template.yaml").read_text(encoding="utf-8"))
    data["vehicle"] = "cruze_diesel_2014"
    (d / "template.yaml").write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return ws


def test_conventional_model_kept_until_an_input_changes(car_ws):
    c = _client(car_ws)
    q = {"dir": "car"}
    m = c.get("/api/model", params=q).json()
    assert "cruze_diesel_2014" in m["vehicle_text"] and m["architecture"] == "conventional"
    assert m["result"] is None                      # a GET never runs it
    r = c.post("/api/model", params=q, json={})
    assert r.status_code == 200, r.text
    out = r.json()
    assert out["vehicle"] == "cruze_diesel_2014"
    rows = out["tables"][0]["rows"]
    assert rows[-1][0] == "test" and rows[-1][1] > 0 and rows[-1][2] > 0
    assert {t["base"] for t in out["traces"]} == {"veh_spd", "eng_spd_out", "fuel_rate"}
    assert all(t["unit"] not in ("m/s", "rad/s", "kg/s") for t in out["traces"])  # display units
    # kept: a new server over the same workspace shows it without running
    kept = _client(car_ws).get("/api/model", params=q).json()
    assert kept["result"] is not None and kept["result"]["tables"] == out["tables"]
    # an input changes (the template): the kept result is stale
    c.post("/api/template", params=q, json={"vehicle_name": "Cruze, roll 2"})
    m = c.get("/api/model", params=q).json()
    assert m["result"] is None and m["stale"]


def test_fuel_difference_beside_a_meter_finding_is_labelled_with_it():
    meter = {"signal": "fuel_rate_test", "kind": "fuel_map", "severity": "warning",
             "message": "the fuel meter reads 6.0 % high against the engine map"}
    other = {"signal": "veh_spd_test", "kind": "spike", "severity": "error", "message": "x"}
    qa = flow.fuel_findings([meter, other])
    assert qa == [meter]
    row = {"en": 2.5, "consistent": False, "uninformative": False}
    assert "model error" not in flow._verdict(row, qa)
    assert "flagged by QA (fuel_map)" in flow._verdict(row, qa)
    assert flow._verdict(row, []).endswith("model error")
    assert "6.0 % high" in flow.qa_label(qa)


def test_samples_qa_flagged_are_masked():
    s = {"t": [0.0, 1.0, 2.0, 3.0], "y": [50.0, 127.5, 127.5, 60.0]}
    findings = [{"signal": "ess_soc_test", "severity": "error", "start_s": 0.5, "end_s": 2.5},
                {"signal": "ess_soc_test", "severity": "info", "start_s": 3.0, "end_s": 3.0}]
    flow._mask_flagged(s, "ess_soc_test", findings)
    assert s["y"] == [50.0, None, None, 60.0] and s["masked"] == 2


def test_state_folder_linked_out_is_refused(car_ws, tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    link = car_ws / flow.STATE_DIR
    kept = car_ws / "kept-state"
    if link.exists():
        link.rename(kept)
    link.symlink_to(outside, target_is_directory=True)
    try:
        c = _client(car_ws)
        for r in (c.get("/api/model", params={"dir": "car"}),
                  c.post("/api/model", params={"dir": "car"}, json={})):
            assert r.status_code == 400 and "symlink" in r.json()["error"], r.text
        assert not list(outside.iterdir())
    finally:
        link.unlink()
        if kept.exists():
            kept.rename(link)
