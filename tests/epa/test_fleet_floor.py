"""The data's floor: the spread of rows a model of the list's columns cannot tell apart."""

from __future__ import annotations

import math

import pytest

from vehval.epa.fleet_floor import MIN_GROUPS, data_floor
from vehval.epa.fleet_summary import fleet_model


def _rec(k: int, meas: float, proc: str = "ftp75", make: str = "Ford", **kw):
    r = {"status": "run", "judged": True, "list": "19tstcar.csv", "procedure": proc,
         "vehicle_id": f"V{k}", "car": f"c{k}", "make": make, "mass_kg": 1500.0,
         "displacement_l": 2.0, "rated_power_w": 1.2e5, "n_v_ratio": 25.0, "axle_ratio": 3.0,
         "target_a_n": 100.0, "target_b_n_per_mps": 1.0, "target_c_n_per_mps2": 0.4,
         "gears": 8, "cylinders": 4, "transmission_class": "automatic",
         "fuel_family": "gasoline", "aspiration": "naturally aspirated",
         "measured_mpg": meas, "predicted_mpg": meas, "error": 0.0}
    return r | kw


def _pairs(spreads: list[float], proc: str = "ftp75") -> list[dict]:
    """One pair of identical rows per spread (measured 30 and 30 e^s), each pair its own car
    (another test weight)."""
    out = []
    for g, s in enumerate(spreads):
        mass = 1000.0 + 50.0 * g
        out += [_rec(2 * g, 30.0, proc, mass_kg=mass),
                _rec(2 * g + 1, 30.0 * math.exp(s), proc, mass_kg=mass)]
    return out


def test_a_pair_gives_the_deviation_of_one_test_from_the_truth():
    """A pair measured 30 and 30 e^s: deviations -+s/2 from the mean, times sqrt(2): a
    perfect prediction errs by exp(-+s/sqrt 2) - 1."""
    s = 0.1
    floor = data_floor(_pairs([s] * MIN_GROUPS))
    st = floor["per_procedure"]["ftp75"]
    assert st["n_groups"] == MIN_GROUPS and st["n_rows"] == 2 * MIN_GROUPS
    assert st["dof"] == MIN_GROUPS
    assert st["sigma"] == pytest.approx(s / math.sqrt(2))  # pooled: (s/2)^2 * 2 per dof
    d = s / math.sqrt(2)
    expected = sorted([abs(math.expm1(-d)), abs(math.expm1(d))])
    assert st["median_abs_error"] == pytest.approx(sum(expected) / 2)
    assert st["share_within_5pct"] == 0.0  # 7.1 % either way


def test_the_share_within_5pct_counts_tests_and_weighs_procedures_by_the_mix():
    rows = _pairs([0.02, 0.02, 0.02, 0.2, 0.2]) + _pairs([0.01] * 5, "hwfet")
    floor = data_floor(rows, {"ftp75": 3, "hwfet": 1})
    assert floor["per_procedure"]["ftp75"]["share_within_5pct"] == pytest.approx(0.6)
    assert floor["per_procedure"]["hwfet"]["share_within_5pct"] == 1.0
    assert floor["share_within_5pct"] == pytest.approx((3 * 0.6 + 1.0) / 4)


def test_rows_the_model_can_tell_apart_are_not_grouped():
    """Another make, another column, a single row, too few groups: no floor stated."""
    rows = [_rec(0, 30.0), _rec(1, 33.0, make="Mazda"), _rec(2, 31.0, mass_kg=1600.0),
            _rec(3, 29.0, cylinders=6)]
    assert data_floor(rows)["per_procedure"] == {}
    assert data_floor(rows)["share_within_5pct"] is None
    few = _pairs([0.02] * (MIN_GROUPS - 1))
    assert data_floor(few)["per_procedure"] == {}
    missing = [r | {"n_v_ratio": None} for r in _pairs([0.02] * MIN_GROUPS)]
    assert data_floor(missing)["per_procedure"] == {}


def test_the_fleet_model_block_states_the_floor_on_its_procedure_mix():
    rows = [r | {"residual_error": 0.01} for r in _pairs([0.02] * 6)]
    block = fleet_model(rows)
    floor = block["floor"]
    assert floor["per_procedure"]["ftp75"]["n_groups"] == 6
    assert floor["share_within_5pct"] == 1.0


def test_the_page_and_the_cli_state_the_floor():
    from vehval.cli.commands_fleet import _fleet_model_lines
    from vehval.epa.fleet_summary import summarise
    from vehval.report.fleet_page import render_fleet_page

    rows = [r | {"residual_error": 0.01, "row_id": f"19tstcar.csv:{k}", "model": "X",
                 "source": f"19tstcar.csv:{k}", "reason_code": "", "coefficients": None}
            for k, r in enumerate(_pairs([0.02] * 5 + [0.2]))]
    summary = summarise(rows) | {"lists": ["19tstcar.csv"]}
    html = render_fleet_page(rows, summary)
    assert "The data&#39;s floor" in html and "83.3 % within 5 %" in html  # 10 of 12 tests
    line = _fleet_model_lines(summary["fleet_model"])[-1]
    assert "6 groups" in line and "within 5 % 83.3 %" in line


def test_the_page_names_the_trees_loss_chosen():
    from vehval.report.fleet_page import _baseline

    st = {"n": 40, "median_abs_error": 0.03, "share_within_5pct": 0.7}
    d = {k: st for k in ("model", "baseline", "boosted", "physics_residual")}
    d |= {"residual_better": True, "loss": {
        "boosted": {"16tstcar.csv": "absolute_error", "19tstcar.csv": "squared_error"},
        "physics_residual": {"16tstcar.csv + 17tstcar.csv": "absolute_error"}}}
    blocks = _baseline({"baseline": {"year_to_year": {"hwfet": d}}})
    text = repr(blocks)
    assert "absolute (16tstcar.csv), squared (19tstcar.csv); absolute (16tstcar.csv + 17tstcar.csv)" in text


def _twin_case() -> list[dict]:
    """2019 rows judged year to year: car 0 has a 2016 twin (mass 0.5 % off) measured 30 and
    31 mpg, car 1 a 2016 car of 3 % more mass (no twin), car 2 another make's twin only."""
    old = [_rec(10, 30.0, list="16tstcar.csv", mass_kg=1507.5),
           _rec(11, 31.0, list="16tstcar.csv", mass_kg=1507.5),
           _rec(12, 40.0, list="16tstcar.csv", mass_kg=1545.0 * 1.03),
           _rec(13, 50.0, list="16tstcar.csv", make="Mazda", mass_kg=1700.0)]
    new = [_rec(0, 32.0) | {"residual_year_error": 0.01},
           _rec(1, 33.0, mass_kg=1545.0) | {"residual_year_error": -0.04},
           _rec(2, 34.0, mass_kg=1700.0) | {"residual_year_error": 0.08}]
    return old + new


def test_a_near_twin_of_the_fit_list_predicts_by_its_measured_figure():
    from vehval.epa.fleet_floor import twin_check

    twins = twin_check(_twin_case(), "residual_year_error",
                       {"19tstcar.csv": {"16tstcar.csv"}})["ftp75"]
    assert twins["twin"]["n"] == 1
    assert twins["twin"]["median_abs_error"] == pytest.approx(1 - math.sqrt(30 * 31) / 32.0)
    assert twins["model"] == {"n": 1, "median_abs_error": pytest.approx(0.01),
                              "share_within_5pct": 1.0}
    alone = twins["model_without_twin"]
    assert alone["n"] == 2 and alone["median_abs_error"] == pytest.approx(0.06)
    assert alone["share_within_5pct"] == pytest.approx(0.5)
    # the same vehicle in the other list is a carried-over test, not a twin
    same = [r | {"vehicle_id": "V0"} if r["list"] == "16tstcar.csv" else r
            for r in _twin_case()]
    assert twin_check(same, "residual_year_error",
                      {"19tstcar.csv": {"16tstcar.csv"}})["ftp75"]["twin"]["n"] == 0


def test_the_year_to_year_block_and_page_state_the_twins():
    from vehval.report.fleet_page import _twins

    block = fleet_model(_twin_case())
    twins = block["floor"]["twins"]
    assert twins["ftp75"]["twin"]["n"] == 1 and twins["ftp75"]["model_without_twin"]["n"] == 2
    text = repr(_twins(twins))
    assert "rows with a twin" in text and "6.00 %" in text
    within = fleet_model([r | {"residual_error": 0.0} for r in _pairs([0.02] * 6)])
    assert "twins" not in within["floor"]  # within a year: no fit list to hold a twin
    from vehval.cli.commands_fleet import _floor_line

    line = _floor_line({"per_procedure": {}, "twins": twins})
    assert line == []  # no floor stated: nothing to add to
    line = _floor_line({**within["floor"], "twins": twins})[-1]
    assert "ftp75 twin 4.70 % (1 rows), model 1.00 % (1 rows), without a twin 6.00 % (2 rows)" \
        in line
