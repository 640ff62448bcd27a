"""The conventional car's validation section states the normalised error En and its verdict
per phase and for the whole test, as `vehval validate` prints them (the report had only
the fuel masses and the error)."""

from __future__ import annotations

from types import SimpleNamespace

from vehval.identify.comparison import PredictionComparison


def test_payload_table_carries_en_and_verdict():
    row = {"test": "t1", "fuel_measured_g": 666.9, "fuel_predicted_g": 667.9,
           "error_rel": 0.0016, "en": 0.048, "consistent": True, "ac_on": False,
           "ac_reason": "auto", "cold_reason": "no coolant",
           "phases": [{"phase": 1, "results_name": "bag1", "measured_g": 302.7,
                       "predicted_g": 303.6, "error_rel": 0.003, "en": 1.4, "consistent": False},
                      {"phase": 2, "measured_g": 364.2, "predicted_g": 364.4,
                       "error_rel": 0.0005, "en": None, "consistent": None}]}
    table = PredictionComparison(row, SimpleNamespace(name="cruze")).payload()["tables"][0]
    assert table["columns"][4:] == ["En", "verdict (|En| <= 1)"]
    assert [r[4:] for r in table["rows"]] == [[1.4, "inconsistent"], [None, "no En"],
                                              [0.048, "consistent"]]
