"""The screen's En marks say what they mean (a bare '?' was unexplained)."""

from __future__ import annotations

from vehval.cli.commands_predict import _en
from vehval.identify.crossval import table


def test_an_uninformative_en_is_named_on_the_predict_line():
    assert _en({"en": -0.13, "uninformative": True}) == " En -0.13 (uninformative)"
    assert _en({"en": 0.5, "uninformative": False}) == " En +0.50"
    assert _en({"en": None}) == ""


def test_the_cross_validation_table_explains_its_mark():
    row = {"identified_from": ["a Test Data"], "test": "b", "cycle": "udds",
           "measured_g": 600.0, "predicted_g": 610.0, "error_rel": 0.0167, "pi95_rel": 0.05,
           "inside_pi95": True, "uncovered_share": 0.0, "en": 0.2, "uninformative": True}
    summary = {"n_predictions": 0}
    text = table({"mode": "leave-one-out", "rows": [row], "skipped": [], "summary": summary})
    assert "+0.20?" in text and "En? : uninformative" in text
    row["uninformative"] = False
    text = table({"mode": "leave-one-out", "rows": [row], "skipped": [], "summary": summary})
    assert "En? :" not in text
