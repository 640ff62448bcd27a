"""Energy audit: the sinks add up to fuel + battery energy; the indicators are consistent."""

from __future__ import annotations

import json

import pytest

from vehval.sim.audit import SINKS, energy_audit


@pytest.mark.parametrize("cycle", ["udds", "hwfet", "us06", "japan1015"])
def test_audit_closes(runs, cycle):
    a = energy_audit(runs[cycle].summary)
    assert a["closes"] and abs(a["closure_rel"]) < 0.005
    assert set(a["sinks"]) == {k for k, _, _ in SINKS}
    ind = a["indicators"]
    s = runs[cycle].summary
    # hand check: the engine efficiency while loaded cannot beat the map's best (~37 %)
    assert 0.2 < ind["engine_efficiency_on"] < 0.40
    assert 0.0 <= ind["friction_brake_share"] <= 1.0
    assert ind["braking_demand_j"] >= s["brake_energy_j"]
    assert 0.0 <= ind["recirculated_j"] <= ind["engine_output_j"]
    # the tractive work at the wheels exceeds the road load minus what braking took back
    assert ind["tractive_energy_j"] > 0.5 * s["road_energy_j"]


def test_audit_detects_a_missing_sink(runs):
    s = dict(runs["udds"].summary)
    s["road_energy_j"] *= 0.9  # 10 % of the road load lost: the audit must not close
    assert not energy_audit(s)["closes"]


def test_cli_audit(tmp_path, capsys):
    from vehval.cli import main

    rc = main(["simulate", "--cycle", "japan1015", "--dt", "1", "--audit", "--json",
               "-o", str(tmp_path / "out")])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["audit"]["closes"] is True
    assert (tmp_path / "out" / "audit.json").exists()
    assert "friction share" in (tmp_path / "out" / "audit.md").read_text()
    rc = main(["simulate", "--cycle", "japan1015", "--dt", "1", "--audit"])
    assert rc == 0 and "recirculation share" in capsys.readouterr().out
