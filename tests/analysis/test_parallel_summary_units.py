"""The parallel hybrid's analysis on screen speaks the display units (it printed m/s)."""

from __future__ import annotations

from vehval.analysis.parallel import ParallelAnalysis


def _doc() -> dict:
    rule = {"name": "assist", "quantity": "shaft torque demand", "op": ">", "threshold": 64.4,
            "support": 0.949, "n": 14826}
    return {"assist_regen": {"assist_threshold": rule, "regen_threshold": {**rule, "name": "regen",
                                                                          "op": "<"},
                             "regen_min_speed_mps": 4.4704, "assist_share_by_gear": {"2": 0.5}},
            "engine_stop": {"rule": {"threshold": 6.7056, "n": 10, "contradicted": 1}}}


def test_speeds_follow_the_unit_system(monkeypatch):
    monkeypatch.setenv("VEHVAL_UNITS", "us")
    text = "\n".join(ParallelAnalysis(_doc()).summary_lines())
    assert "no regen below 10 mph" in text and "engine stops below 15 mph" in text
    monkeypatch.setenv("VEHVAL_UNITS", "metric")
    text = "\n".join(ParallelAnalysis(_doc()).summary_lines())
    assert "no regen below 16.1 km/h" in text and "engine stops below 24.1 km/h" in text
    assert "m/s" not in text
