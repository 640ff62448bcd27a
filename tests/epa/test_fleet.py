"""The fleet runner: every row of a list run or accounted for, resumable, on Dask, with the
regression baseline, the report and the what-if (small lists written in tmp_path)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from helpers.epa_lists import HEADER, camry_rows, write_list
from vehval.batch.fleet import run_fleet
from vehval.cli import main
from vehval.epa.fleet import ROW_COLUMNS, plan_fleet, predict_jobs, read_fleet
from vehval.epa.fleet_baseline import cross_validate, fit_ridge, predict_ridge
from vehval.epa.fleet_summary import outliers
from vehval.epa.fleet_whatif import parse_change, whatif
from vehval.errors import ConfigError


@pytest.fixture(autouse=True)
def _fewer_trees(monkeypatch):
    """The synthetic lists' laws are smooth and small: a third of the trees at three times
    the learning rate fit them alike, in a third of the time."""
    from vehval.epa import fleet_baseline

    monkeypatch.setattr(fleet_baseline, "BOOST", fleet_baseline.BOOST | {
        "max_iter": 100, "learning_rate": 3 * fleet_baseline.BOOST["learning_rate"]})

ADFE = "Analytically Derived FE?"
FLEET_HEADER = [*HEADER, ADFE, "# of Cylinders and Rotors"]


def _car(vid: str, **kw) -> list[dict]:
    rows = camry_rows(vid=vid, **kw)
    for r in rows:
        r["Test Number"] = f"{vid}-{r['Test Number']}"
        r[ADFE] = "No"
        r["# of Cylinders and Rotors"] = "4"
    return rows


def _mixed_rows() -> list[dict]:
    """Two runnable cars and one row of every reason not to run."""
    good = _car("A1") + _car("A2", weight=4000, target=(30.0, 0.25, 0.009))
    hybrid = _car("H1", model="SEDAN HYBRID")
    sc03 = _car("S1")[:1]
    sc03[0].update({"Test Procedure Cd": "95", "Test Procedure Description": "SC03"})
    adfe = _car("D1")[1:]
    adfe[0][ADFE] = "Yes"
    zero = _car("Z1")[1:]
    zero[0]["RND_ADJ_FE"] = "0"
    nocoef = _car("N1")[1:]
    nocoef[0]["Target Coef A (lbf)"] = ""
    unknown_tr = _car("U1")
    for r in unknown_tr:
        r["Tested Transmission Type Code"] = "ZZ"
    one_hp = _car("P1")
    for r in one_hp:
        r["Rated Horsepower"] = "1"
    nv0 = _car("V1")
    for r in nv0:
        r["N/V Ratio"] = "0"
    electric = _car("E1")[1:]
    electric[0].update({"Test Fuel Type Cd": "62", "Test Fuel Type Description": "Electricity"})
    hydrogen = _car("G1")[1:]
    hydrogen[0].update({"Test Fuel Type Cd": "50", "Test Fuel Type Description": "Hydrogen 5"})
    cold_co = _car("K1")[:1]
    cold_co[0].update({"Test Procedure Cd": "11", "Test Procedure Description": "Cold CO",
                       "Test Fuel Type Cd": "26",
                       "Test Fuel Type Description": "Cold CO Regular (Tier 2)"})
    return (good + hybrid + sc03 + adfe + zero + nocoef + unknown_tr + one_hp + nv0
            + electric + hydrogen + cold_co)


@pytest.fixture
def mixed_list(tmp_path):
    return write_list(tmp_path / "19tstcar.csv", _mixed_rows(), header=FLEET_HEADER)


def _by_vid(records):
    out: dict[str, list] = {}
    for r in records:
        out.setdefault(r["vehicle_id"], []).append(r)
    return out


def test_every_row_is_run_or_not_run_with_its_reason(mixed_list):
    tests, lists = read_fleet([mixed_list])
    plan = plan_fleet(tests)
    records = [*plan.not_run, *predict_jobs(plan.jobs)]
    assert lists == ["19tstcar.csv"] and len(records) == len(tests) == plan.n_rows
    assert set(records[0]) == set(ROW_COLUMNS)
    by = _by_vid(records)
    assert {r["status"] for v in ("A1", "A2") for r in by[v]} == {"run"}
    expect = {"H1": "hybrid", "S1": "procedure_not_modelled", "D1": "analytically_derived",
              "Z1": "placeholder_values", "N1": "missing_coefficients",
              "U1": "transmission_not_modelled", "P1": "specs_not_usable",
              "V1": "specs_not_usable", "E1": "electric", "G1": "fuel_not_modelled",
              "K1": "procedure_not_modelled"}
    for vid, code in expect.items():
        for r in by[vid]:
            assert r["status"] == "not_run" and r["reason_code"] == code, (vid, r["reason"])
            # one line naming the row
            assert r["reason"].startswith(f"19tstcar.csv:{r['source'].split(':')[1]}: ")
            assert "\n" not in r["reason"]
    assert "1" in by["P1"][0]["reason"] and "kW/L" in by["P1"][0]["reason"]
    assert "N/V" in by["V1"][0]["reason"]
    assert "'ZZ'" in by["U1"][0]["reason"]
    # an analytically derived row is never judged (nor run)
    assert not any(r["judged"] for r in by["D1"])
    for r in by["A1"] + by["A2"]:
        assert r["judged"] and math.isfinite(r["error"]) and abs(r["error"]) < 0.5
        assert r["predicted_mpg"] == pytest.approx(r["measured_mpg"] * (1 + r["error"]))
    # each row on its own weight: the heavier car reads lower
    hw = {r["vehicle_id"]: r["predicted_mpg"] for r in records
          if r["procedure"] == "hwfet" and r["status"] == "run"}
    assert hw["A2"] < hw["A1"]


def test_fleet_run_writes_tables_summary_report_and_resumes(mixed_list, tmp_path):
    import duckdb

    out = tmp_path / "out"
    s = run_fleet([mixed_list], out, workers=1)
    assert s["n_rows"] == len(_mixed_rows()) and s["n_run"] == 4 and s["n_failed"] == 0
    assert s["not_run_by_reason"]["specs_not_usable"] == 4
    assert set(s["errors"]) == {"ftp75", "hwfet"} and s["run"]["n_rows_simulated"] == 4
    assert {"per_technology", "hwfet_ftp_bias", "outliers", "baseline", "per_list"} <= set(s)
    con = duckdb.connect(str(out / "fleet.duckdb"), read_only=True)
    try:
        n, n_run = con.execute("SELECT count(*), count(*) FILTER (WHERE status = 'run') "
                               "FROM fleet_rows").fetchone()
        reasons = con.execute("SELECT count(*) FROM fleet_rows WHERE status <> 'run' AND "
                              "reason IS NULL").fetchone()[0]
    finally:
        con.close()
    assert (n, n_run, reasons) == (s["n_rows"], 4, 0)
    assert json.loads((out / "fleet.json").read_text())["n_rows"] == n
    html = (out / "fleet.html").read_text()
    assert "Every row accounted for" in html and "Outliers" in html
    # a rerun takes every car from the store and simulates nothing
    cars = sorted(p.stat().st_mtime_ns for p in (out / "cars").iterdir())
    again = run_fleet([mixed_list], out, workers=1)
    assert again["run"]["n_cars_cached"] == again["run"]["n_cars"] == 2
    assert again["run"]["n_rows_simulated"] == 0
    assert sorted(p.stat().st_mtime_ns for p in (out / "cars").iterdir()) == cars
    assert again["errors"] == s["errors"]


def test_a_list_without_a_runnable_row_is_one_line_and_exit_2(tmp_path, capsys):
    rows = _car("H1", model="SEDAN HYBRID")
    path = write_list(tmp_path / "16tstcar.csv", rows, header=FLEET_HEADER)
    with pytest.raises(ConfigError, match="no runnable row"):
        run_fleet([path], tmp_path / "o", workers=1)
    assert main(["epa", "fleet", str(path), "-o", str(tmp_path / "o2"), "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "16tstcar.csv" in err[0] and "hybrid 2" in err[0]
    assert not (tmp_path / "o2" / "fleet.json").exists()


def test_a_list_without_runnable_rows_beside_a_good_one_is_noted(mixed_list, tmp_path):
    bad = write_list(tmp_path / "16tstcar.csv", _car("H1", model="SEDAN HYBRID"),
                     header=FLEET_HEADER)
    s = run_fleet([bad, mixed_list], tmp_path / "o", workers=1, report=False)
    assert s["per_list"]["16tstcar.csv"]["n_run"] == 0 and s["n_run"] == 4
    assert len(s["notes"]) == 1 and s["notes"][0].startswith("16tstcar.csv: no runnable row")


def test_cli_fleet_json(mixed_list, tmp_path, capsys):
    assert main(["epa", "fleet", str(mixed_list), "-o", str(tmp_path / "o"), "--workers", "1",
                 "--json", "--no-report"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["n_run"] == 4 and s["outputs"]["html"] is None
    assert not (tmp_path / "o" / "fleet.html").exists()


def test_dask_run_equals_the_loop(mixed_list, tmp_path):
    loop = run_fleet([mixed_list], tmp_path / "loop", workers=1, report=False)
    dask = run_fleet([mixed_list], tmp_path / "dask", workers=2, report=False)
    assert dask["run"]["workers"] == 2
    assert dask["errors"] == loop["errors"]


def test_ridge_recovers_a_log_linear_law_and_cross_validates():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(200, 5))
    y = 3.0 + x @ np.array([0.3, -0.2, 0.1, 0.0, 0.05])
    model = fit_ridge(x, y)
    assert np.allclose(predict_ridge(model, x), y, atol=1e-2)
    # records whose mpg follows the weight exactly: the baseline beats a model 10 % off
    recs = []
    for k in range(60):
        m = 1200.0 + 20 * k
        recs.append({"status": "run", "judged": True, "list": "19tstcar.csv",
                     "procedure": "hwfet", "vehicle_id": f"V{k}", "mass_kg": m,
                     "displacement_l": 2.0, "rated_power_w": 1.2e5, "n_v_ratio": 25.0,
                     "axle_ratio": 3.0, "target_a_n": 100.0, "target_b_n_per_mps": 1.0,
                     "target_c_n_per_mps2": 0.4, "gears": 8, "cylinders": 4,
                     "transmission_class": "automatic", "fuel_family": "gasoline",
                     "aspiration": "naturally aspirated", "measured_mpg": 1e5 / m,
                     "error": -0.10})
    cmp = cross_validate(recs)["within_year"]["hwfet"]
    assert cmp["baseline"]["median_abs_error"] < 0.01 and not cmp["model_better"]
    assert all(r["baseline_error"] is not None for r in recs)


def test_physics_plus_regression_residual_is_reported_apart():
    """The physics' own error explained by the list's columns (a bias growing with N/V)
    is removed by the learned residual, cross-validated by vehicle; the physics model's
    figures and its comparison with the baseline stay those of the physics alone."""
    recs = []
    for lst in ("16tstcar.csv", "19tstcar.csv"):
        for k in range(60):
            m, nv = 1200.0 + 20 * k, 20.0 + (k * 7) % 15
            meas = 1e5 / m
            err = 0.01 * (nv - 27.0)  # the physics reads high with N/V
            recs.append({"status": "run", "judged": True, "list": lst, "procedure": "ftp75",
                         "vehicle_id": f"V{k}", "mass_kg": m, "displacement_l": 2.0,
                         "rated_power_w": 1.2e5, "n_v_ratio": nv, "axle_ratio": 3.0,
                         "target_a_n": 100.0, "target_b_n_per_mps": 1.0,
                         "target_c_n_per_mps2": 0.4, "gears": 8, "cylinders": 4,
                         "transmission_class": "automatic", "fuel_family": "gasoline",
                         "aspiration": "naturally aspirated", "measured_mpg": meas,
                         "predicted_mpg": meas * (1 + err), "error": err})
    cmp = cross_validate(recs)
    for scheme in ("within_year", "year_to_year"):
        d = cmp[scheme]["ftp75"]
        assert d["model"]["median_abs_error"] > 0.03  # the physics' own error, unchanged
        assert d["physics_residual"]["median_abs_error"] < 0.005
    assert all(r["residual_error"] is not None and r["residual_year_error"] is not None
               for r in recs)


def _row(lst: str, k: int, make: str, meas: float, err: float, coef: str | None = None):
    return {"status": "run", "judged": True, "list": lst, "procedure": "ftp75",
            "vehicle_id": f"{lst}-{make}-{k}", "make": make, "mass_kg": 1200.0 + 20 * k,
            "displacement_l": 2.0, "rated_power_w": 1.2e5, "n_v_ratio": 25.0,
            "axle_ratio": 3.0, "target_a_n": 100.0, "target_b_n_per_mps": 1.0,
            "target_c_n_per_mps2": 0.4, "gears": 8, "cylinders": 4,
            "transmission_class": "automatic", "fuel_family": "gasoline",
            "aspiration": "naturally aspirated", "measured_mpg": meas,
            "predicted_mpg": meas * (1 + err), "error": err, "coefficients": coef}


def test_the_boosted_baseline_is_told_the_make():
    """Two makes with the same columns, one 12 % more frugal: the ridge on the columns cannot
    tell them apart (about 6 % off each), the boosted trees and the learned residual can."""
    recs = [_row("19tstcar.csv", k, make, (1e5 / (1200.0 + 20 * k)) * (1.12 if make == "MAZDA"
                                                                           else 1.0), 0.0)
            for k in range(40) for make in ("MAZDA", "Ford")]
    for r in recs:  # physics blind to the make as well
        r["predicted_mpg"] = 1e5 / r["mass_kg"] * 1.06
        r["error"] = r["predicted_mpg"] / r["measured_mpg"] - 1
    d = cross_validate(recs)["within_year"]["ftp75"]
    assert d["baseline"]["median_abs_error"] > 0.04
    assert d["boosted"]["median_abs_error"] < 0.025  # steps of trees on a smooth law
    assert d["physics_residual"]["median_abs_error"] < 0.01 and d["residual_better"]


def test_the_year_to_year_residual_learns_the_judging_coefficients_own_error():
    """2019 rows judged with a 2016 fit (5 % high) get their residual from the 2016 rows built
    with that same fit (5 % high: learned and removed), never from the 2016 rows judged with
    the 2019 fit (7 % low), which would double the error instead of removing it."""
    recs, training = [], []
    for k in range(40):
        m = 1e5 / (1200.0 + 20 * k)
        recs.append(_row("19tstcar.csv", k, "Ford", m, 0.05, "fit2016"))
        recs.append(_row("16tstcar.csv", k, "Ford", m, -0.07, "fit2019"))
        training.append(_row("16tstcar.csv", k, "Ford", m, 0.05, "fit2016"))
        training.append(_row("19tstcar.csv", k, "Ford", m, -0.07, "fit2019"))
    cmp = cross_validate(recs, training)["year_to_year"]["ftp75"]
    assert cmp["model"]["median_abs_error"] > 0.04
    assert cmp["physics_residual"]["median_abs_error"] < 0.005
    for r in recs:
        assert abs(r["residual_year_error"]) < 0.005 and r["boosted_year_error"] is not None
    # without the training rows there is no fit with the same coefficients: no residual
    plain = [{k: v for k, v in r.items() if not k.startswith("residual")} for r in recs]
    cross_validate(plain)
    assert all(r.get("residual_year_error") is None for r in plain)


def test_the_trees_loss_is_chosen_on_the_fit_lists_own_folds():
    """A physics error of +4 % for one make, 0 for the other, and one row in five 25 % off:
    the squared loss follows the mean and is pulled by those rows, the absolute loss follows
    the median and is not. The absolute loss is chosen on each list's within-year folds, and
    the year-to-year fit takes the loss chosen on the list it is fitted on."""
    from vehval.epa.fleet_baseline import _fit_predict, _usable, boosted, make_key

    recs = []
    for lst in ("16tstcar.csv", "19tstcar.csv"):
        for k in range(60):
            make = ("Ford", "MAZDA")[k % 2]
            err = (0.04 if make == "MAZDA" else 0.0) + (0.25 if k % 5 == 4 else 0.0)
            recs.append(_row(lst, k, make, 1e5 / (1200.0 + 20 * k), err))
    cmp = cross_validate([dict(r) for r in recs])
    for scheme, fit_lists in (("within_year", {"16tstcar.csv", "19tstcar.csv"}),
                              ("year_to_year", {"16tstcar.csv", "19tstcar.csv"})):
        loss = cmp[scheme]["ftp75"]["loss"]["physics_residual"]
        assert set(loss) == fit_lists and set(loss.values()) == {"absolute_error"}
    chosen = cmp["within_year"]["ftp75"]["physics_residual"]["median_abs_error"]
    assert chosen < 0.005  # the median rows are exact
    squared = [dict(r) for r in recs]  # the squared loss alone on the same rows
    makes = {m: i for i, m in enumerate(sorted({make_key(r) for r in squared}))}
    groups: dict = {}
    for r, x in _usable(squared, makes):
        groups.setdefault((r["list"], r["procedure"]), []).append((r, x))
    _fit_predict(groups, lambda r: math.log(r["predicted_mpg"] / r["measured_mpg"]),
                 ("m", "e", "ym", "ye"), lambda r, p: r["predicted_mpg"] / math.exp(p), boosted)
    assert float(np.median([abs(r["e"]) for r in squared])) > max(2 * chosen, 0.01)
    # a list judged with its own fit (every row in-sample) chooses on all its rows
    own = [dict(r) | {"in_sample": True} for r in recs]
    cross_validate(own)
    assert float(np.median([abs(r["residual_error"]) for r in own])) < 0.005


def test_the_trees_fits_in_processes_give_the_same_figures(monkeypatch):
    from vehval.epa import fleet_baseline

    recs = [_row(lst, k, ("Ford", "MAZDA")[k % 2], 1e5 / (1200.0 + 20 * k),
                 0.03 * math.sin(k)) for lst in ("16tstcar.csv", "19tstcar.csv")
            for k in range(30)]
    here = [dict(r) for r in recs]
    cmp_here = cross_validate(here, jobs=1)
    monkeypatch.setattr(fleet_baseline, "PARALLEL_MIN_ROWS", 0)
    apart = [dict(r) for r in recs]
    assert cross_validate(apart, jobs=2) == cmp_here
    keys = [k for k in here[0] if k.startswith(("boosted", "residual", "baseline"))]
    assert len(keys) >= 12
    assert [[r[k] for k in keys] for r in apart] == [[r[k] for k in keys] for r in here]


def test_the_fleet_models_en_takes_its_scatter_from_the_other_lists():
    """U_model of a 2019 row: the robust sigma of the fleet model's within-year errors on the
    2016 rows (never its own list's), less the lists' measurement part in quadrature."""
    from vehval.epa.fleet_baseline import MIN_ROWS, residual_verdicts

    recs = [{"list": "16tstcar.csv", "procedure": "ftp75", "measured_mpg": 30.0,
             "u_meas_mpg": 1.8, "residual_error": math.expm1(0.04 * (-1) ** k)}
            for k in range(2 * MIN_ROWS)]
    judged_row = {"list": "19tstcar.csv", "procedure": "ftp75", "measured_mpg": 30.0,
                  "u_meas_mpg": 1.8, "residual_error": 0.5, "residual_year_mpg": 31.0}
    residual_verdicts([*recs, judged_row])
    u_rel = math.sqrt((1.4826 * 0.04) ** 2 - 0.03 ** 2)
    assert judged_row["residual_u_model_mpg"] == pytest.approx(2 * u_rel * 31.0)
    assert judged_row["residual_en"] == pytest.approx(
        1.0 / math.hypot(2 * u_rel * 31.0, 1.8), rel=1e-6)
    assert "residual_en" not in recs[0]  # no year-to-year prediction: no verdict
    alone = dict(judged_row)
    del alone["residual_u_model_mpg"], alone["residual_en"]
    residual_verdicts([alone])  # one list: nothing else to take the scatter from
    assert "residual_en" not in alone


def test_the_fleet_model_block_judges_the_residual_against_the_targets():
    from vehval.epa.fleet_summary import TARGETS, fleet_model, worst_group_bias

    recs = [_row("19tstcar.csv", k, "Ford", 30.0, 0.0) | {"residual_error": e, "car": f"c{k}"}
            for k, e in enumerate([0.01, -0.02, 0.04, 0.06, -0.01] * 6)]
    block = fleet_model(recs)
    assert block["scheme"] == "within_year" and block["n_judged"] == 30
    assert block["errors"]["ftp75"]["median_abs_error"] == pytest.approx(0.02)
    assert block["share_within_5pct"] == pytest.approx(0.8)
    assert block["met"]["median_abs_error"]["ftp75"] and block["met"]["share_within_5pct"]
    assert block["targets"] == TARGETS
    assert block["per_list"]["19tstcar.csv"]["n_judged"] == 30
    tech = {"cylinders": {"unknown": {"ftp75": {"n": 30, "median_error": 0.2}},
                          "4": {"ftp75": {"n": 30, "median_error": -0.04}},
                          "3": {"ftp75": {"n": 5, "median_error": 0.09}}}}
    assert worst_group_bias(tech) == {"grouping": "cylinders", "group": "4",
                                      "procedure": "ftp75", "n": 30, "median_error": -0.04}


def test_outliers_are_named():
    rows = [{"row_id": f"l.csv:{k}", "make": "M", "model": "X", "vehicle_id": f"V{k}",
             "procedure": "ftp75", "transmission_class": "automatic",
             "aspiration": "naturally aspirated", "measured_mpg": 30.0,
             "predicted_mpg": 30.0 * (1 + e), "error": e}
            for k, e in enumerate([0.01, -0.01, 0.0, 0.02, -0.02, 0.005, 0.12])]
    out = outliers(rows)
    assert [o["row_id"] for o in out] == ["l.csv:6"]
    assert "robust sigma" in out[0]["why"] and "10 %" in out[0]["why"]


def test_whatif_answers_weight_road_load_and_axle(mixed_list):
    tests, _ = read_fleet([mixed_list])
    res = whatif(tests, "A1", weight="-200lb", road_load="-5%")
    assert len(res["rows"]) == 2
    for r in res["rows"]:
        assert r["change"] > 0.01 and r["answer_mpg"] > r["measured_mpg"]
        lo, hi = r["interval_mpg"]
        assert lo < r["answer_mpg"] < hi and r["u_change_rel"] > 0
    heavy = whatif(tests, "A1", weight="+10%", procedure="hwfet")["rows"][0]
    assert heavy["change"] < 0 and heavy["procedure"] == "hwfet"
    axle = whatif(tests, "A1", axle="3.2")
    assert axle["changes"]["n_v_ratio"] == pytest.approx(24.7 * 3.2 / 2.8)
    with pytest.raises(ConfigError, match="--road-load '-5lb'"):
        whatif(tests, "A1", road_load="-5lb")
    with pytest.raises(ConfigError, match="no runnable row"):
        whatif(tests, "H1", weight="-200lb")
    with pytest.raises(Exception, match="did you mean A1"):
        whatif(tests, "A11", weight="-200lb")


def test_parse_change():
    assert parse_change("-200lb", "--weight", ("lb", "kg", "%")) == ("-", 200.0, "lb")
    assert parse_change("3.2", "--axle", ("", "%")) == ("", 3.2, "")
    with pytest.raises(ConfigError):
        parse_change("abc", "--axle", ("", "%"))


def test_cli_whatif(mixed_list, capsys):
    assert main(["epa", "whatif", str(mixed_list), "--vehicle-id", "A1", "--weight",
                 "-200lb", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["vehicle_id"] == "A1" and len(res["rows"]) == 2
    assert main(["epa", "whatif", str(mixed_list), "--vehicle-id", "A1"]) == 2
    assert "at least one of --weight" in capsys.readouterr().err


def test_real_list_every_row_accounted_for(shared_data):
    path = shared_data / "real" / "epa_test_car_list" / "19tstcar.csv"
    if not path.exists():
        pytest.skip("2019 Test Car List not present")
    tests, _ = read_fleet([path])
    plan = plan_fleet(tests)
    assert plan.n_to_run + len(plan.not_run) == len(tests) == plan.n_rows
    assert all(r["reason"] and r["reason_code"] for r in plan.not_run)
    derived = {t.source for t in tests if t.analytically_derived}
    assert derived and not derived & {t.source for j in plan.jobs for t in j.tests}


def test_an_interrupted_run_keeps_the_cars_it_finished(mixed_list, tmp_path, monkeypatch):
    import vehval.epa.fleet as fleet

    real, calls = fleet.predict_car, []

    def second_interrupts(job):
        calls.append(job.key)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return real(job)

    monkeypatch.setattr(fleet, "predict_car", second_interrupts)
    with pytest.raises(KeyboardInterrupt):
        run_fleet([mixed_list], tmp_path / "o", workers=1)
    assert not (tmp_path / "o" / "fleet.json").exists()
    monkeypatch.setattr(fleet, "predict_car", real)
    s = run_fleet([mixed_list], tmp_path / "o", workers=1, report=False)
    assert s["run"]["n_cars_cached"] == 1 and s["run"]["n_rows_simulated"] == 2
    assert s["n_run"] == 4


def test_e85_rows_run_on_e85(tmp_path):
    """A flex-fuel car: its E85 rows run on E85 (energy per gallon about 72 % of
    certification gasoline's), its gasoline rows on gasoline; a diesel row is named."""
    gas = _car("F1")
    e85 = _car("F1")
    for r in e85:
        r["Test Number"] += "E"
        r.update({"Test Fuel Type Cd": "19",
                  "Test Fuel Type Description": "E85 (85% Ethanol 15% EPA Unleaded Gasoline)",
                  "RND_ADJ_FE": str(round(float(r["RND_ADJ_FE"]) * 0.72, 1))})
    path = write_list(tmp_path / "19tstcar.csv", gas + e85, header=FLEET_HEADER)
    tests, _ = read_fleet([path])
    plan = plan_fleet(tests)
    assert not plan.not_run and sorted(j.fuel for j in plan.jobs) == ["e85", "gasoline"]
    recs = predict_jobs(plan.jobs)
    hw = {r["fuel_family"]: r["predicted_mpg"] for r in recs if r["procedure"] == "hwfet"}
    assert hw["e85"] / hw["gasoline"] == pytest.approx((29.17 * 781.7) / (42.60 * 740.0),
                                                       rel=0.03)
    e85_specs = next(j.specs for j in plan.jobs if j.fuel == "e85")
    from vehval.epa.specs import vehicle_from_specs

    assert vehicle_from_specs(e85_specs).engine.fuel == "ethanol_e85"


DIESEL = "Federal Cert Diesel 7-15 PPM Sulfur"


def test_diesel_rows_run_on_a_compression_ignition_engine(tmp_path):
    """Diesel rows were all 'fuel not modelled': now the car is built for its diesel rows with
    the diesel technology (no throttle pumping, lean full load, its own efficiency,
    friction and idle, rated power at 4000 rpm) and runs on diesel fuel."""
    gas = _car("G2")
    diesel = _car("D2")
    for r in diesel:
        r.update({"Test Fuel Type Cd": "20", "Test Fuel Type Description": DIESEL})
    path = write_list(tmp_path / "19tstcar.csv", gas + diesel, header=FLEET_HEADER)
    tests, _ = read_fleet([path])
    plan = plan_fleet(tests)
    assert not plan.not_run and sorted(j.fuel for j in plan.jobs) == ["diesel", "gasoline"]
    d_specs = next(j.specs for j in plan.jobs if j.fuel == "diesel")
    g_specs = next(j.specs for j in plan.jobs if j.fuel == "gasoline")
    assert d_specs.engine_technology == "diesel"
    from vehval.epa.specs import vehicle_from_specs

    veh = vehicle_from_specs(d_specs)
    assert veh.engine.fuel == "diesel" and veh.engine.max_speed_rpm == pytest.approx(4400.0)
    assert "no enrichment" in veh.engine.sources["fuel_rate_g_per_s"]
    assert "diesel" in veh.engine.sources["fuel_rate_g_per_s"]  # the diesel's coefficients
    recs = predict_jobs(plan.jobs)
    assert all(r["status"] == "run" and r["judged"] for r in recs)
    hw = {r["fuel_family"]: r["predicted_mpg"] for r in recs if r["procedure"] == "hwfet"}
    # a gallon of diesel holds about 14 % more energy and the engine is more efficient
    assert hw["diesel"] / hw["gasoline"] > 1.15
    assert {r["aspiration"] for r in recs if r["fuel_family"] == "diesel"} == {"diesel"}
    assert g_specs.engine_technology != "diesel"


def test_a_changed_model_runs_the_stored_cars_again(mixed_list, tmp_path, monkeypatch):
    import vehval.epa.fleet as fleet

    run_fleet([mixed_list], tmp_path / "o", workers=1, report=False)
    monkeypatch.setattr(fleet, "model_fingerprint", lambda: "another model")
    s = run_fleet([mixed_list], tmp_path / "o", workers=1, report=False)
    assert s["run"]["n_cars_cached"] == 0 and s["run"]["n_rows_simulated"] == 4


def test_duckdb_keeps_missing_values_null(mixed_list, tmp_path):
    import duckdb

    run_fleet([mixed_list], tmp_path / "o", workers=1, report=False)
    con = duckdb.connect(str(tmp_path / "o" / "fleet.duckdb"), read_only=True)
    try:
        nan, null, miss = con.execute(
            "SELECT count(*) FILTER (WHERE isnan(predicted_mpg)), "
            "count(*) FILTER (WHERE predicted_mpg IS NULL), "
            "max(trace_n_miss) FROM fleet_rows").fetchone()
        zero_fe = con.execute("SELECT measured_mpg FROM fleet_rows WHERE vehicle_id = 'Z1'"
                              ).fetchone()[0]
    finally:
        con.close()
    assert nan == 0 and null > 0 and miss is not None and zero_fe is None


def test_a_scheduler_that_does_not_answer_is_one_line(mixed_list, tmp_path, capsys):
    import socket

    with socket.socket() as s:  # a free port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    assert main(["epa", "fleet", str(mixed_list), "-o", str(tmp_path / "o"),
                 "--scheduler", f"tcp://127.0.0.1:{port}"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--scheduler" in err[0]
    assert not (tmp_path / "o" / "fleet.json").exists()


@pytest.mark.parametrize("model", ["NX 300h AWD", "PRIUS c", "330e", "X5 xDrive40e",
                                   "GLC 350e 4MATIC", "XC90 T8 AWD", "INSIGHT", "NIRO"])
def test_hybrids_known_by_their_makers_names_are_not_run(model, tmp_path):
    path = write_list(tmp_path / "19tstcar.csv", _car("H2", model=model) + _car("A1"),
                      header=FLEET_HEADER)
    tests, _ = read_fleet([path])
    plan = plan_fleet(tests)
    hyb = [r for r in plan.not_run if r["vehicle_id"] == "H2"]
    assert len(hyb) == 2 and {r["reason_code"] for r in hyb} == {"hybrid"}
    assert "in the model name" in hyb[0]["reason"]
    assert [j.tests[0].vehicle_id for j in plan.jobs] == ["A1"]


@pytest.mark.parametrize("model", ["SONATA SE", "E 300", "F150 PICKUP 2WD", "CX-3", "330i",
                                   "XC90 T6 AWD", "M340i xDrive"])
def test_conventional_names_are_not_taken_for_hybrids(model, tmp_path):
    path = write_list(tmp_path / "19tstcar.csv", _car("C1", model=model), header=FLEET_HEADER)
    tests, _ = read_fleet([path])
    plan = plan_fleet(tests)
    assert not plan.not_run and len(plan.jobs) == 1


def test_a_city_figure_at_the_highway_figure_is_a_hybrid_whatever_its_name(tmp_path):
    rows = _car("M1", model="MALIBU")
    rows[0]["RND_ADJ_FE"] = "61.1"  # the list's FTP-75 of an unnamed hybrid
    rows[0]["FE Bag 1"], rows[0]["FE Bag 2"], rows[0]["FE Bag 3"] = "55", "63", "62"
    rows[1]["RND_ADJ_FE"] = "61.9"
    path = write_list(tmp_path / "19tstcar.csv", rows + _car("A1"), header=FLEET_HEADER)
    tests, _ = read_fleet([path])
    plan = plan_fleet(tests)
    why = {r["reason_code"] for r in plan.not_run}
    assert why == {"hybrid"} and "0.99 of its HWFET" in plan.not_run[0]["reason"]
    # the camry's 37.0 / 58.2 = 0.64 is a conventional car's
    assert [j.tests[0].vehicle_id for j in plan.jobs] == ["A1"]


def _coefficients_fitted_on(tmp_path, name: str, list_name: str, eta: float) -> str:
    """The package's coefficients as fitted on ``list_name``, with another NA efficiency."""
    from importlib import resources

    import yaml

    from vehval.epa import technology as tech

    data = yaml.safe_load(resources.files("vehval").joinpath(tech.DEFAULT_FILE).read_text())
    data["provenance"]["fit_lists"] = [list_name]
    data["engine"]["spark_na"]["indicated_efficiency"]["value"] = eta
    data["engine"]["spark_na"]["indicated_efficiency"]["interval"] = [0.2, 0.6]
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return str(path)


def test_each_list_is_judged_with_a_fit_of_another_list(tmp_path):
    """--coefficients: a list fitted on is judged with the other file (out-of-sample); a
    list that every file was fitted on is marked in-sample."""
    a = write_list(tmp_path / "16tstcar.csv", _car("A6", year=2016), header=FLEET_HEADER)
    b = write_list(tmp_path / "19tstcar.csv", _car("B9"), header=FLEET_HEADER)
    f16 = _coefficients_fitted_on(tmp_path, "f16.yaml", "16tstcar.csv", 0.40)
    f19 = _coefficients_fitted_on(tmp_path, "f19.yaml", "19tstcar.csv", 0.30)
    s = run_fleet([a, b], tmp_path / "o", workers=1, coefficients=[f16, f19])
    html = (tmp_path / "o" / "fleet.html").read_text()
    assert "Out of sample: 4 judged rows" in html and "{_pc" not in html
    assert "within 5 %: " + f"{100 * s['out_of_sample']['share_within_5pct']:.1f} %" in html
    used = {c["file"]: c for c in s["coefficients"]}
    assert used[f16]["lists_judged"] == ["19tstcar.csv"]
    assert used[f19]["lists_judged"] == ["16tstcar.csv"]
    assert s["out_of_sample"]["n_judged"] == s["n_judged"] == 4
    assert s["out_of_sample"]["n_in_sample"] == 0
    # each car built a second time with the fit of its own list, to fit the residual only
    assert s["run"]["n_cars_training"] == 2 and s["n_rows"] == 4
    # the 2016 car (same specs as the 2019 one) built with the less efficient engine
    import duckdb

    con = duckdb.connect(str(tmp_path / "o" / "fleet.duckdb"), read_only=True)
    rows = con.execute("SELECT list, procedure, predicted_mpg, in_sample, coefficients "
                       "FROM fleet_rows ORDER BY list, procedure").fetchall()
    con.close()
    pred = {(x[0], x[1]): x[2] for x in rows}
    assert pred[("16tstcar.csv", "hwfet")] < 0.85 * pred[("19tstcar.csv", "hwfet")]
    assert {x[3] for x in rows} == {False} and "f19.yaml" in rows[0][4]
    # one file fitted on the list: its rows run with it, marked in-sample, and the
    # out-of-sample statistics leave them out
    s1 = run_fleet([b], tmp_path / "o1", workers=1, report=False, coefficients=[f19])
    assert s1["out_of_sample"]["n_judged"] == 0 and s1["per_list"]["19tstcar.csv"][
        "n_in_sample"] == 2
    assert s1["coefficients"][0]["in_sample_lists"] == ["19tstcar.csv"]


def test_cross_year_uses_the_packaged_fits(mixed_list, tmp_path, capsys):
    from vehval.epa import technology as tech

    fits = tech.packaged_fits()
    assert len(fits) >= 2 and all(f.fit_lists for f in fits)
    assert main(["epa", "fleet", str(mixed_list), "-o", str(tmp_path / "o"), "--workers", "1",
                 "--no-report", "--cross-year"]) == 0
    out = capsys.readouterr().out
    assert "out of sample (4 rows)" in out and "in-sample lists: none" in out


def test_a_bad_coefficients_file_is_one_line(mixed_list, tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("engine: {spark_na: {friction_scale: {value: 9}}}\n", encoding="utf-8")
    assert main(["epa", "fleet", str(mixed_list), "-o", str(tmp_path / "o"), "--workers", "1",
                 "--coefficients", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.yaml" in err[0] and "friction_scale" in err[0]
    assert not (tmp_path / "o" / "fleet.json").exists()


def test_a_test_carried_over_from_the_fitted_list_is_in_sample(tmp_path):
    """The 2019 list repeats some 2016 tests: judged with the 2016 fit they are the rows
    fitted on, not out-of-sample, and a rerun from the store keeps the marks of its lists."""
    old = _car("C1", year=2016)
    new = _car("C1") + _car("N2")
    a = write_list(tmp_path / "16tstcar.csv", old, header=FLEET_HEADER)
    b = write_list(tmp_path / "19tstcar.csv", new, header=FLEET_HEADER)
    f16 = _coefficients_fitted_on(tmp_path, "f16.yaml", "16tstcar.csv", 0.40)
    s = run_fleet([b], tmp_path / "o", workers=1, report=False, coefficients=[f16])
    assert s["out_of_sample"]["n_judged"] == 4  # the 2016 list not read: nothing to see
    s = run_fleet([a, b], tmp_path / "o", workers=1, report=False, coefficients=[f16])
    assert s["run"]["n_cars_cached"] == 2  # the 2019 cars from the store, relabelled
    per = s["per_list"]
    assert per["19tstcar.csv"]["n_in_sample"] == 2 and per["16tstcar.csv"]["n_in_sample"] == 2
    assert s["out_of_sample"]["n_judged"] == 2


def test_a_four_phase_ftp_is_a_hybrid_mild_ones_included(tmp_path):
    rows = _car("R1", model="1500 4X4")
    rows[0]["FE Bag 4"] = "21.0"  # the four-phase FTP of a 48 V mild hybrid
    path = write_list(tmp_path / "19tstcar.csv", rows + _car("A1"), header=FLEET_HEADER)
    tests, _ = read_fleet([path])
    plan = plan_fleet(tests)
    assert {r["vehicle_id"] for r in plan.not_run} == {"R1"}
    assert all(r["reason_code"] == "hybrid" and "bag 4" in r["reason"] for r in plan.not_run)


def test_every_judged_row_has_its_normalised_error(mixed_list, tmp_path):
    """En = (model - listed) / sqrt(U_model^2 + U_meas^2): U_meas from the lists'
    vehicle-level reproducibility of the procedure, U_model from the coefficients' ranges."""
    from vehval.uncertainty.defaults import precision_default

    s = run_fleet([mixed_list], tmp_path / "o", workers=1, report=False)
    tests, _ = read_fleet([mixed_list])
    records = predict_jobs(plan_fleet(tests).jobs)
    judged_rows = [r for r in records if r["judged"]]
    assert judged_rows
    for r in judged_rows:
        d = precision_default(r["procedure"], "conventional")
        assert r["u_meas_mpg"] == pytest.approx(2 * d.s_R_vehicle * r["measured_mpg"], rel=1e-6)
        assert r["u_model_mpg"] > 0
        en = (r["predicted_mpg"] - r["measured_mpg"]) / math.hypot(r["u_model_mpg"],
                                                                   r["u_meas_mpg"])
        assert r["en"] == pytest.approx(en)
    ver = s["out_of_sample"]["verdicts"]
    assert set(ver) == {"ftp75", "hwfet"} and all(v["n"] == 2 for v in ver.values())
    share = np.mean([abs(r["en"]) <= 1 for r in judged_rows if r["procedure"] == "hwfet"])
    assert ver["hwfet"]["share_consistent"] == pytest.approx(share)


def test_cli_whatif_speaks_the_display_units_and_names_bad_choices(mixed_list, capsys):
    args = ["epa", "whatif", str(mixed_list), "--vehicle-id", "A1", "--weight", "-200lb"]
    assert main([*args, "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert main(args) == 0
    us = capsys.readouterr().out
    assert main(["--units", "metric", *args]) == 0
    metric = capsys.readouterr().out
    r = res["rows"][0]
    assert f"listed {r['measured_mpg']:.1f} mpg" in us and "L/100 km" not in us
    litres = 235.2146 / r["measured_mpg"]  # L/100 km of an mpg figure, by hand
    assert f"listed {litres:.2f} L/100 km" in metric and " mpg" not in metric
    lo, hi = (235.2146 / v for v in reversed(r["interval_mpg"]))
    assert f"[{lo:.2f}, {hi:.2f}]" in metric
    assert main([*args, "--procedure", "udds"]) == 2
    assert "--procedure udds: unknown procedure; give one of ftp75, hwfet, us06" in \
        capsys.readouterr().err
    assert main([*args, "--config", "99"]) == 2
    assert "--config 99: no row of the lists; its configurations:" in capsys.readouterr().err
