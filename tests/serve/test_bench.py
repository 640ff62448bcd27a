"""Template review and QA triage through the workbench's API (no browser).

The same flows as tests/serve/test_browser.py, checked on the files they write: the saved
template is `template init`'s plus the edits (comments kept), and a drop decided in the page
gives the `template_final.yaml` of `vehval qa` with that decision in the template.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from vehval.cli import main  # noqa: E402
from vehval.io.readers import read_raw  # noqa: E402
from vehval.io.template import Template  # noqa: E402

from .helpers import FUEL_COLUMN, expected_mpg  # noqa: E402
from .helpers import client as _client  # noqa: E402

FUEL = "gasoline_e0"
DENSITY = 740.0  # gasoline_e0 of the fuel table [kg/m³]




def _init_data(ws: Path) -> tuple[str, dict]:
    text = (ws / "virtual" / "template.yaml").read_text(encoding="utf-8")
    return text, yaml.safe_load(text)


def _fuel_hints(model: dict) -> list[dict]:
    ch = next(c for f in model["files"] for c in f["channels"] if c["raw"] == FUEL_COLUMN)
    return [h for h in ch["hints"] if h["signal"] == "fuel_rate_test"]


def test_unit_fix_flow(workspace, synth_dir):
    init_text, data = _init_data(workspace)
    c = _client(workspace)
    m = c.get("/api/test", params={"dir": "virtual"}).json()
    assert m["saved"] and m["error"] is None
    # the user declares the fuel: QA runs and hints at the fuel unit
    m = c.post("/api/template", params={"dir": "virtual"}, json={"fuel": FUEL}).json()
    assert m["error"] is None, m["error"]
    hints = _fuel_hints(m)
    assert hints and hints[0]["kind"] in ("unit", "unit_suspect")
    assert "fuel_rate_test" in hints[0]["message"]
    # the impossible figure is withheld by the QA gate, naming the signal
    assert m["headline"]["fuel_economy_mpg"] is None
    assert "fuel_rate_test" in str(m["headline"]["withheld"])
    # mg/s -> g/s: the headline comes within range
    m = c.post("/api/template", params={"dir": "virtual"},
               json={"channels": [{"file": 0, "raw": FUEL_COLUMN, "unit": "g/s"}]}).json()
    assert m["error"] is None and not _fuel_hints(m)
    mpg = m["headline"]["fuel_economy_mpg"]
    expected = expected_mpg(synth_dir, DENSITY)
    # the measured fuel is the simulation's plus sensor noise (no fault injected): 3 %
    assert mpg == pytest.approx(expected, rel=0.03) and not m["headline"].get("withheld")
    # the saved template is init's plus the two edits, comments kept
    saved = (workspace / "virtual" / "template.yaml").read_text(encoding="utf-8")
    data["fuel"] = FUEL
    data["files"][0]["channels"][FUEL_COLUMN]["unit"] = "g/s"
    assert yaml.safe_load(saved) == data
    comments = [ln for ln in init_text.splitlines() if ln.startswith("#")]
    assert comments and comments[0].startswith("# fuel:")   # init's placeholder block...
    assert not [ln for ln in saved.splitlines() if ln.startswith("#")]  # ...gone: fuel is set
    body = [ln for ln in saved.splitlines() if not ln.startswith("#")]
    assert body == Template.model_validate(data).to_yaml().splitlines()
    # the outputs `vehval qa -o virtual/qa` writes
    qa = workspace / "virtual" / "qa"
    assert {p.name for p in qa.iterdir()} >= {"findings.json", "results.json",
                                             "validated.parquet", "template_final.yaml"}


def test_drop_in_page_equals_cli_selection(workspace, tmp_path):
    _, data = _init_data(workspace)
    c = _client(workspace)
    c.post("/api/template", params={"dir": "virtual"},
           json={"fuel": FUEL, "channels": [{"file": 0, "raw": FUEL_COLUMN, "unit": "g/s"}]})
    reason = "load cell drifting this week"
    m = c.post("/api/selection", params={"dir": "virtual"},
               json={"signal": "dyno_frc_test", "action": "drop", "reason": reason}).json()
    assert m["error"] is None
    assert m["selection"]["dropped"]["dyno_frc_test"] == f"dropped by the user: {reason}"
    page_final = (workspace / "virtual" / "qa" / "template_final.yaml").read_text(encoding="utf-8")
    # the CLI: the same template with the decision written in its selection, then `vehval qa`
    data["fuel"] = FUEL
    data["files"][0]["channels"][FUEL_COLUMN]["unit"] = "g/s"
    data["selection"] = {"drop": {"dyno_frc_test": reason}}
    tpl = Template.model_validate(data).save(tmp_path / "cli.yaml")
    assert main(["qa", str(workspace / "virtual" / "run_d3.txt"), "-t", str(tpl),
                 "-o", str(tmp_path / "out")]) == 0
    assert page_final == (tmp_path / "out" / "template_final.yaml").read_text(encoding="utf-8")
    # the decision is recorded with the user's reason (the signal is removed at import)
    assert yaml.safe_load(page_final)["selection"]["drop"]["dyno_frc_test"] == reason
    # clearing the decision removes it from the template
    m = c.post("/api/selection", params={"dir": "virtual"},
               json={"signal": "dyno_frc_test", "action": "clear"}).json()
    assert "dyno_frc_test" not in m["user_selection"]["drop"]
    r = c.post("/api/selection", params={"dir": "virtual"},
               json={"signal": "dyno_frc_test", "action": "drop", "reason": " "})
    assert r.status_code == 400 and "reason" in r.json()["error"]


def test_bad_unit_gives_the_cli_message_and_keeps_the_file(workspace, tmp_path, capsys):
    path = workspace / "virtual" / "template.yaml"
    before = path.read_text(encoding="utf-8")
    c = _client(workspace)
    r = c.post("/api/template", params={"dir": "virtual"},
               json={"channels": [{"file": 0, "raw": FUEL_COLUMN, "unit": "furlongs/fortnight"}]})
    assert r.status_code == 400
    page_msg = r.json()["error"]
    assert path.read_text(encoding="utf-8") == before  # nothing half-written
    bad = yaml.safe_load(before)
    bad["files"][0]["channels"][FUEL_COLUMN]["unit"] = "furlongs/fortnight"
    (tmp_path / "template.yaml").write_text(yaml.safe_dump(bad), encoding="utf-8")
    capsys.readouterr()
    assert main(["import", str(workspace / "virtual" / "run_d3.txt"), "-t",
                 str(tmp_path / "template.yaml"), "-o", str(tmp_path / "x.parquet")]) == 2
    cli_msg = capsys.readouterr().err.strip()
    assert cli_msg == f"vehval: error: {page_msg}"


def test_channel_plot_is_decimated_then_exact_on_zoom(workspace):
    c = _client(workspace)
    raw = read_raw(workspace / "virtual" / "run_d3.txt")
    t, y = raw.data[raw.time_name], raw.data["Dyno_Speed"]
    whole = c.get("/api/channel", params={"dir": "virtual", "file": "run_d3.txt",
                                          "raw": "Dyno_Speed", "n": 2000}).json()
    assert not whole["exact"] and whole["n_window"] == t.size and len(whole["t"]) <= 2000
    assert max(whole["y"]) == pytest.approx(np.nanmax(y), abs=0)  # no extreme lost
    zoom = c.get("/api/channel", params={"dir": "virtual", "file": "run_d3.txt",
                                         "raw": "Dyno_Speed", "t0": 100, "t1": 200}).json()
    assert zoom["exact"] and zoom["unit"] == "mph"
    sel = (t >= 100 - 0.1 - 1e-9) & (t <= 200 + 0.1 + 1e-9)
    np.testing.assert_array_equal(np.array(zoom["y"], float), y[sel])  # rtol 0: the file's samples


def test_bad_raw_file_shows_the_cli_message(tmp_path, capsys):
    test = tmp_path / "ws" / "broken"
    test.mkdir(parents=True)
    (test / "run.csv").write_bytes(b"Time[s],Speed[km/h]\n0,1\n1,\x00\x00garbage\n2")
    c = _client(tmp_path / "ws")
    r = c.get("/api/test", params={"dir": "broken"})
    assert r.status_code == 200
    page_msg = r.json()["error"]
    assert page_msg
    capsys.readouterr()
    rc = main(["template", "init", str(test / "run.csv"), "-o", str(tmp_path / "t.yaml")])
    cli = capsys.readouterr().err.strip()
    assert rc == 2 and cli.startswith("vehval: error: ")
    # the same sentence; the CLI names the path as given, the page the file's own path
    assert cli.split("run.csv", 1)[1] == page_msg.split("run.csv", 1)[1]
