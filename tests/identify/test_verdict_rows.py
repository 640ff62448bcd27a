"""The normalised error of predicted fuel rows (`predict`, `identify --cross-validate`) by
hand, without a simulation."""

from __future__ import annotations

import math

import pytest

from vehval.identify.verdicts import judge_rows
from vehval.uncertainty.defaults import precision_default


def _row(test, cycle, meas, pred, pi=None, u_res=None, in_sample=False):
    return {"test": test, "cycle": cycle, "fuel_measured_g": meas, "fuel_predicted_g": pred,
            "pi95_rel": pi, "results_fuel_U_g": u_res, "in_sample": in_sample,
            "phases": [{"phase": 1, "measured_g": meas / 2, "predicted_g": pred / 2,
                        "pi95_rel": pi}]}


def test_rows_by_hand_and_set_verdict():
    rows = [_row("a", "udds", 700.0, 707.0, 0.05, 6.0), _row("b", "hwfet_x2", 600.0, 594.0, 0.04),
            _row("c", "nedc", 500.0, 505.0, 0.06, 5.0), _row("d", "udds", 400.0, 500.0,
                                                             in_sample=True)]
    verdict, notes = judge_rows(rows)
    s_ftp = precision_default("ftp75", "conventional").s_r
    s_hw = precision_default("hwfet", "conventional").s_r
    a = rows[0]
    den = math.hypot(0.05 * 707.0, math.hypot(6.0, 2 * s_ftp * 700.0))
    assert a["en"] == pytest.approx(7.0 / den)
    assert a["phases"][0]["en"] == pytest.approx(3.5 / math.hypot(0.05 * 353.5,
                                                                  2 * s_ftp * 350.0))
    assert rows[1]["s_r"] == s_hw and rows[1]["u_meas_g"] == pytest.approx(2 * s_hw * 600)
    assert rows[2]["s_r"] == s_ftp            # NEDC borrows the FTP-75's, said in a note
    assert any("nedc" in n and "ftp75" in n for n in notes)
    assert verdict is not None and verdict["n"] == 3 and verdict["tests"] == ["a", "b", "c"]
    assert verdict["mean_error_pct"] == pytest.approx(100 * (0.01 - 0.01 + 0.01) / 3)
    assert verdict["verdict"] == "consistent with the data"
    # in-sample rows get an En but stay out of the set
    assert rows[3]["en"] is not None and rows[3]["en"] > 1


def test_fewer_than_three_held_out_tests_no_verdict():
    verdict, notes = judge_rows([_row("a", "udds", 700.0, 707.0)])
    assert verdict is None and any("1 comparison(s)" in n for n in notes)
    assert any("U_model = 0" in n for n in notes)
