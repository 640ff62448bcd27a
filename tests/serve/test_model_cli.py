"""Model and test on the page's API, and the `vehval serve` command."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")
from starlette.testclient import TestClient  # noqa: E402

from vehval.cli import main  # noqa: E402
from vehval.serve.app import create_app  # noqa: E402

SRC = Path(__file__).resolve().parents[2] / "src"


def test_model_overlay_with_verdicts(synth_dir, tmp_path):
    test = tmp_path / "ws" / "prius"
    test.mkdir(parents=True)
    for f in (*synth_dir.glob("*_d3.txt"), *synth_dir.glob("*_obd.csv"), synth_dir / "template.yaml"):
        shutil.copy(f, test / f.name)
    app = create_app(tmp_path / "ws")
    wb = app.state.workbench
    c = TestClient(app, base_url="http://127.0.0.1",
                   headers={"X-Vehval-Token": wb.token, "X-CSRF-Token": wb.csrf})
    r = c.post("/api/model", params={"dir": "prius"}, json={})
    assert r.status_code == 200, r.text
    m = r.json()
    assert m["vehicle"] == "prius_2004"
    bases = {t["base"] for t in m["traces"]}
    assert {"veh_spd", "eng_spd_out", "ess_soc"} <= bases
    spd = next(t for t in m["traces"] if t["base"] == "veh_spd")
    assert spd["simulated"]["name"].endswith("_simu") and spd["measured"]["name"].endswith("_test")
    assert spd["unit"] in ("mph", "km/h")                                 # display units
    soc = next(t for t in m["traces"] if t["base"] == "ess_soc")
    assert soc["unit"] == "%" and 20 < max(y for y in soc["measured"]["y"] if y is not None) <= 100
    titles = [t["title"] for t in m["tables"]]
    assert any("summary" in t for t in titles)
    # the fuel mass's normalised error beside the summary's % difference, in grams
    ne = m["normalised_error"]
    assert ne["u_model_kg"] > 0 and ne["u_meas_kg"] > 0 and ne["s_r"] > 0
    assert ne["en"] == pytest.approx((ne["model_kg"] - ne["measured_kg"])
                                     / math.hypot(ne["u_model_kg"], ne["u_meas_kg"]), rel=1e-12)
    assert ne["verdict"] == ("consistent" if abs(ne["en"]) <= 1 else "inconsistent")
    assert titles[1] == "Verdict by the normalised error (fuel mass)"
    t = m["tables"][1]
    row = dict(zip(t["columns"], t["rows"][0]))
    assert row["unit"] == "g" and row["En"] == pytest.approx(ne["en"], abs=1e-3)
    assert row["U_model (k = 2)"] == pytest.approx(1e3 * ne["u_model_kg"])
    assert row["U_meas (k = 2)"] == pytest.approx(1e3 * ne["u_meas_kg"])
    assert row["error [%]"] == pytest.approx(100 * (ne["model_kg"] / ne["measured_kg"] - 1))
    assert row["verdict"].startswith(ne["verdict"])
    # the model's verdict with its En joins the page's headline; its figure: one panel per
    # quantity on one linked time axis, one unit per axis, in display units
    from vehval.report.finding_figures import panel_units

    h = c.get("/api/test", params={"dir": "prius"}).json()["headline"]
    assert h["model"]["en"] == pytest.approx(ne["en"]) and f"En = {ne['en']:+.2f}" in h["verdict"]
    units = panel_units(m["figure"])
    assert len(units) >= 3 and all(len(u) == 1 for u in units.values())
    assert {"mph", "rpm", "%"} <= {next(iter(u)) for u in units.values()}
    assert all(m["figure"]["layout"][f"xaxis{i}"].get("matches") == "x"
               for i in range(2, len(units) + 1))


def test_model_needs_a_vehicle(workspace):
    app = create_app(workspace)
    wb = app.state.workbench
    c = TestClient(app, base_url="http://127.0.0.1",
                   headers={"X-Vehval-Token": wb.token, "X-CSRF-Token": wb.csrf})
    r = c.post("/api/model", params={"dir": "virtual"}, json={})
    assert r.status_code == 400 and "vehicle" in r.json()["error"]


def _env() -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), *sys.path]))


def test_serve_help_loads_no_web_stack():
    code = ("import sys\nfrom vehval.cli import main\nrc = main(['serve', '--help'])\n"
            "print('MODULES', ' '.join(sorted(sys.modules)))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=_env(), timeout=120)
    assert "--no-browser" in proc.stdout and "--port" in proc.stdout
    mods = set(proc.stdout.split("MODULES ", 1)[1].split())
    assert not {m for m in mods if m.split(".")[0] in ("starlette", "uvicorn", "jinja2", "numpy")}


def test_serve_errors_are_one_line(tmp_path, capsys):
    assert main(["serve", str(tmp_path / "missing"), "--no-browser"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vehval: error: ") and "missing" in err and "Traceback" not in err
    assert main(["serve", str(tmp_path), "--host", "0.0.0.0", "--no-browser"]) == 2
    assert "this machine only" in capsys.readouterr().err


def test_serve_prints_a_token_url_and_answers(tmp_path):
    proc = subprocess.Popen([sys.executable, "-m", "vehval", "serve", str(tmp_path), "--port", "0",
                             "--no-browser"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=_env())
    try:
        url = None
        deadline = time.monotonic() + 60
        while url is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if line.startswith("open: "):
                url = line.split("open: ", 1)[1].strip()
        assert url and url.startswith("http://127.0.0.1:") and "?token=" in url
        base = url.split("/?")[0]
        for _ in range(100):
            try:
                urllib.request.urlopen(base + "/", timeout=5)
            except urllib.error.HTTPError as exc:
                assert exc.code == 403  # up, and no token -> 403
                break
            except urllib.error.URLError:
                time.sleep(0.1)
        else:
            pytest.fail("the server did not answer")
        import http.cookiejar

        opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(http.cookiejar.CookieJar()))
        with opener.open(url, timeout=10) as r:  # token -> cookie -> the home page
            assert r.status == 200 and b"vehval workbench" in r.read()
    finally:
        proc.terminate()
        proc.wait(timeout=20)
