"""`vehval epa validate`: the normalised error of every figure and the set verdict."""

from __future__ import annotations

import json
import math

import pytest

from helpers.epa_lists import row, write_list
from vehval.cli import main
from vehval.epa import read_test_car_list
from vehval.epa.validation import validate_tests
from vehval.epa.verdicts import measurement_precision
from vehval.uncertainty.defaults import precision_default

WEIGHTS = (3000, 3125, 3250, 3375, 3500, 3625)


def _hwfet_rows(fe: list[float] | None = None, orig: str = "EPA") -> list[dict]:
    """Six HWFETs of one car at six test weights (measured figures ``fe``)."""
    return [row(number=f"H{k}", code=3, desc="HWFE", weight=w, orig=orig,
                fe=71.0 if fe is None else repr(fe[k]))
            for k, w in enumerate(WEIGHTS)]


@pytest.fixture(scope="module")
def predicted(tmp_path_factory) -> list[float]:
    """The model's own HWFET figures at the six weights."""
    path = write_list(tmp_path_factory.mktemp("pred") / "16tstcar.csv", _hwfet_rows())
    val = validate_tests("prius_2016", read_test_car_list(path), dt=1.0)
    by = {c.test: c.predicted_mpg for c in val.comparisons if c.item == "overall"}
    return [by[f"H{k}"] for k in range(len(WEIGHTS))]


def _validate(tmp_path, fe: list[float], *extra: str) -> dict:
    path = write_list(tmp_path / "16tstcar.csv", _hwfet_rows(fe))
    rc = main(["epa", "validate", str(path), "--vehicle", "prius_2016", "--tests",
               "model=PRIUS", "--dt", "1", "--json", *extra])
    assert rc in (0, None)
    return path


def _doc(capsys) -> dict:
    return json.loads(capsys.readouterr().out)


def test_en_per_figure_by_hand(tmp_path, capsys, predicted):
    """U_model = 0: En = (pred - meas) / (2 s meas) with s the packaged vehicle-level s_R of
    hybrid HWFETs (the car is not one the vehicle file was calibrated on)."""
    meas = [p * f for p, f in zip(predicted, (0.97, 1.0, 1.02, 0.99, 1.05, 0.96))]
    _validate(tmp_path, meas, "--model-uncertainty", "none")
    doc = _doc(capsys)
    s = precision_default("hwfet", "hybrid").s_R_vehicle
    assert s is not None
    rows = {c["test"]: c for c in doc["comparisons"]}
    for k, m in enumerate(meas):
        c = rows[f"H{k}"]
        p = c["predicted_mpg"]
        assert c["u_model"] == 0.0
        assert c["u_meas"] == pytest.approx(2 * s * m, rel=1e-3)
        assert c["en"] == pytest.approx((p - m) / (2 * s * m), rel=1e-3, abs=1e-3)
        assert c["consistent"] == (abs(c["en"]) <= 1)
        assert c["uninformative"] is False
        assert c["precision"]["different_source"] is True
        assert "s_R_vehicle" in c["precision"]["basis"]
        assert c["error"] == pytest.approx(p / m - 1, abs=1e-4)  # the % error stays
    sv = doc["set_verdict"]
    errs = [p / m - 1 for p, m in zip(predicted, meas)]
    assert sv["n"] == 6
    assert sv["mean_error_pct"] == pytest.approx(100 * sum(errs) / 6, abs=0.01)
    assert sv["n_consistent"] == sum(abs(rows[f"H{k}"]["en"]) <= 1 for k in range(6))
    assert sv["verdict"] == "consistent with the data"


def test_model_uncertainty_enters_en(tmp_path, capsys, predicted):
    """The linearised U_model of the HWFET enters every HWFET figure by its share."""
    meas = [p * 1.04 for p in predicted]
    _validate(tmp_path, meas)
    doc = _doc(capsys)
    mu = doc["model_uncertainty"]["hwfet"]
    assert mu["method"] == "linear" and mu["U_rel"] > 0
    for c in doc["comparisons"]:
        u_model = mu["U_rel"] * c["predicted_mpg"]
        assert c["u_model"] == pytest.approx(u_model, rel=1e-3)
        den = math.hypot(u_model, c["u_meas"])
        assert c["en"] == pytest.approx((c["predicted_mpg"] - c["measured_mpg"]) / den,
                                        rel=1e-3)


def test_biased_and_unbiased_sets(tmp_path, capsys, predicted):
    """The same car through the real command: measured figures scattered by 1 % around the
    model's are consistent; the model 9 % above every measured figure is biased."""
    noise = (0.01, -0.012, 0.004, -0.006, 0.011, -0.008)
    _validate(tmp_path, [p * (1 + e) for p, e in zip(predicted, noise)],
              "--model-uncertainty", "none")
    fair = _doc(capsys)["set_verdict"]
    assert fair["verdict"] == "consistent with the data" and not fair["biased"]
    assert fair["n_consistent"] == 6
    _validate(tmp_path, [p / 1.09 * (1 + e) for p, e in zip(predicted, noise)],
              "--model-uncertainty", "none")
    biased = _doc(capsys)["set_verdict"]
    assert biased["biased"] and biased["verdict"].startswith("biased by +9.")
    lo, hi = biased["mean_error_ci_pct"]
    assert lo < 9.0 < hi
    # on screen: the En column and the set verdict line
    _validate(tmp_path, [p / 1.09 for p in predicted], "--model-uncertainty", "none")
    capsys.readouterr()
    path = tmp_path / "16tstcar.csv"
    main(["epa", "validate", str(path), "--vehicle", "prius_2016", "--tests", "model=PRIUS",
          "--dt", "1", "--model-uncertainty", "none"])
    out = capsys.readouterr().out
    assert " En " in out.splitlines()[0]
    assert "set verdict (held-out, one figure per test, n = 6): biased by +9.0 +- 0.0 %" in out


def test_monte_carlo_of_too_few_draws_refused(tmp_path, capsys, predicted):
    path = write_list(tmp_path / "16tstcar.csv", _hwfet_rows(list(predicted)))
    rc = main(["epa", "validate", str(path), "--vehicle", "prius_2016", "--tests",
               "model=PRIUS", "--dt", "1", "--model-uncertainty", "monte-carlo",
               "--draws", "20"])
    err = capsys.readouterr().err
    assert rc == 2 and "--draws 20: must be 0 or within [100, 10000] draws" in err


def test_source_rule():
    """s_r on the calibration lab's rows of the car, s_R in the other lab, the vehicle-level
    s_R for another car."""
    labs, cars = {("16-ZV1H", "MFR")}, {"16-ZV1H"}
    d = precision_default("ftp75", "conventional")
    same = measurement_precision("ftp75", "conventional", "16-ZV1H", "MFR", labs, cars)
    other_lab = measurement_precision("ftp75", "conventional", "16-ZV1H", "EPA", labs, cars)
    other_car = measurement_precision("ftp75", "conventional", "16-XX", "EPA", labs, cars)
    assert (same["s"], same["different_source"]) == (d.s_r, False)
    assert (other_lab["s"], other_lab["different_source"]) == (d.s_R, True)
    assert (other_car["s"], other_car["different_source"]) == (d.s_R_vehicle, True)
    # a figure the family cannot give falls back and says so (hybrid: no setting-level s_R)
    h = measurement_precision("us06", "hybrid", "16-ZV1H", "EPA", labs, cars)
    assert h["s"] is not None and h["different_source"]
    unknown = measurement_precision("cd_udds", "hybrid", "16-XX", "EPA", labs, cars)
    assert unknown["s"] is None


def test_set_verdict_over_all_tests_when_some_are_in_sample(tmp_path, capsys, predicted):
    """A row carrying a calibration test number of the vehicle file is in-sample: the
    held-out verdict leaves it out, ``set_verdict_all`` counts it (one figure per test)."""
    rows = _hwfet_rows([p * 0.99 for p in predicted])
    rows[0] = row(number="GTYX10038683", code=3, desc="HWFE", weight=WEIGHTS[0], orig="MFR",
                  fe=repr(predicted[0] * 0.99))
    path = write_list(tmp_path / "16tstcar.csv", rows)
    main(["epa", "validate", str(path), "--vehicle", "prius_2016", "--tests", "model=PRIUS",
          "--dt", "1", "--model-uncertainty", "none", "--json"])
    doc = _doc(capsys)
    assert any(c["in_sample"] for c in doc["comparisons"])
    assert doc["set_verdict"]["n"] == 5
    every = doc["set_verdict_all"]
    assert every["n"] == 6 and every["verdict"] == "consistent with the data"
    assert "GTYX10038683 hwfet overall" in every["figures"]
    main(["epa", "validate", str(path), "--vehicle", "prius_2016", "--tests", "model=PRIUS",
          "--dt", "1", "--model-uncertainty", "none"])
    out = capsys.readouterr().out
    assert "set verdict (all tests, in-sample included, not a prediction, n = 6)" in out
    assert "against s_r alone (one lab's repeats) the scatter explains" in out
    # no in-sample test: no second verdict
    _validate(tmp_path, [p * 0.99 for p in predicted], "--model-uncertainty", "none")
    assert _doc(capsys)["set_verdict_all"] is None



def test_vehicle_without_ranges_noted_once(tmp_path, capsys):
    """A car built from the list (no parameter ranges) on an FTP-75 and an HWFET:
    U_model = 0 is said once, not once per procedure."""
    from helpers.epa_lists import HEADER, camry_rows

    path = write_list(tmp_path / "19tstcar.csv", camry_rows(), header=HEADER)
    car = tmp_path / "car.yaml"
    assert main(["epa", "vehicle", str(path), "--make", "MAKER", "--model", "SEDAN XLE",
                 "--year", "2019", "-o", str(car)]) in (0, None)
    capsys.readouterr()
    main(["epa", "validate", str(path), "--vehicle", str(car), "--tests", "make=MAKER",
          "--dt", "1", "--json"])
    notes = _doc(capsys)["notes"]
    said = [n for n in notes if "no parameter carries an uncertainty" in n]
    assert len(said) == 1, notes


def test_report_sentence_names_both_verdicts():
    """The report's verdict text: the held-out sentence, and the all-tests one when given."""
    from vehval.epa.validation import EpaValidation
    from vehval.report.epa import verdict_text

    sv = {"n": 4, "verdict": "consistent with the data", "mean_error_pct": -1.0,
          "mean_error_ci_pct": [-2.0, 0.0], "bias_limit_pct": 1.3, "n_consistent": 4,
          "coverage_ci": [0.4, 1.0]}
    val = EpaValidation.__new__(EpaValidation)
    val.set_verdict, val.set_verdict_note = sv, ""
    val.set_verdict_all, val.set_verdict_all_note = None, ""
    assert "all tests" not in verdict_text(val)
    val.set_verdict_all = dict(sv, n=12)
    text = verdict_text(val)
    assert "Set verdict (held-out, one figure per test, n = 4)" in text
    assert "Set verdict (all tests, in-sample included, not a prediction, n = 12)" in text
