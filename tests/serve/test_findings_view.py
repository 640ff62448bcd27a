"""The test page's headline and findings on the virtual Prius: the report's headline (U,
J1711 status, the user's unit system), every finding of every stage (the results stage's
SAE J1711 finding too), each with a figure made for its kind, one unit per axis."""

from __future__ import annotations

import pytest

pytest.importorskip("starlette")
pytest.importorskip("httpx2")

from vehval.report.finding_figures import panel_units  # noqa: E402

from .helpers import FUEL_COLUMN  # noqa: E402
from .helpers import client as _client  # noqa: E402


def test_headline_findings_and_their_figures(workspace, monkeypatch):
    c = _client(workspace)
    # a GET never runs QA: the figure of a finding before the run is a 409
    r = c.get("/api/finding", params={"dir": "virtual", "i": 0})
    assert r.status_code == 409 and "POST /api/run" in r.json()["error"]
    m = c.post("/api/template", params={"dir": "virtual"},
               json={"fuel": "gasoline_e0",
                     "channels": [{"file": 0, "raw": FUEL_COLUMN, "unit": "g/s"}]}).json()
    assert m["error"] is None, m["error"]
    h = m["headline"]
    assert h["kind"] == "headline" and " ± " in h["figure"] and h["figure"].index("mpg") < \
        h["figure"].index("L/100 km")
    assert h["j1711"] == "beyond_tolerance_uncorrected"
    assert any(c.startswith("SAE J1711 beyond tolerance uncorrected") for c in h["caveats"])
    stages = [f["stage"] for f in m["findings"]]
    assert "results" in stages and stages.index("results") > stages.index("qa")
    for i, f in enumerate(m["findings"]):
        r = c.get("/api/finding", params={"dir": "virtual", "i": i}).json()
        assert "error" not in r, r
        fig = r["figure"]
        assert all(len(u) == 1 for u in panel_units(fig).values()), (f["kind"], fig["layout"])
    bad = c.get("/api/finding", params={"dir": "virtual", "i": len(m["findings"])})
    assert bad.status_code == 400 and "finding(s)" in bad.json()["error"]
    # the user's unit system: L/100 km first
    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    h = c.get("/api/test", params={"dir": "virtual"}).json()["headline"]
    assert h["figure"].index("L/100 km") < h["figure"].index("mpg")
