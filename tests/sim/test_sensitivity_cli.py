"""`vehval sensitivity` on every architecture, its refusals and its display units.

Each test here failed before the fix it names (the user tour's defects 1-9)."""

from __future__ import annotations

import json

import pytest
import yaml

from vehval.cli import main
from vehval.display import ENV_VAR
from vehval.sim.sensitivity import MPG, PLAIN_MPG, configuration_pairs, sensitivity, swing_pct
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle
from vehval.vehicle.definition import _vehicles_dir

#: 1 mpg (mile per US gallon) in L/100 km: 100 km / (1.609344 km) x 3.785411784 L
L100_PER_MPG = 100 * 3.785411784 / 1.609344


def _with_uncertainty(tmp_path, name: str, spec: dict[str, dict]) -> str:
    """A packaged vehicle file with ``spec`` ({block: {parameter: uncertainty}}) added."""
    data = yaml.safe_load((_vehicles_dir() / f"{name}.yaml").read_text())
    for blk, unc in spec.items():
        data[blk]["uncertainty"] = {**(data[blk].get("uncertainty") or {}), **unc}
    p = tmp_path / f"{name}_unc.yaml"
    p.write_text(yaml.safe_dump(data))
    return str(p)


def _one_line_error(capsys, argv: list[str]) -> str:
    rc = main(argv)
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1 and "internal error" not in err, (rc, err)
    return err


def test_conventional_car_ranks_its_plain_fuel_economy(tmp_path):
    """Defect 1: KeyError 'fuel_economy_soc_corrected_mpg' on a conventional car."""
    p = _with_uncertainty(tmp_path, "cruze_diesel_2014",
                          {"body": {"mass_kg": {"range": [1600.0, 1800.0]}}})
    res = sensitivity(p, ["ece15"], dt=1.0)
    veh = load_vehicle(p)
    base = simulate(veh, "ece15", dt=1.0).summary[PLAIN_MPG]
    low = simulate(veh.with_overrides({"body.mass_kg": 1600.0}), "ece15", dt=1.0).summary
    (row,) = res["parameters"]
    c = row["cycles"]["ece15"]
    assert res["base"]["ece15"]["mpg"] == pytest.approx(base, rel=1e-12)
    assert c["low_mpg"] == pytest.approx(low[PLAIN_MPG], rel=1e-12)
    assert c["low_pct"] == pytest.approx(100 * (low[PLAIN_MPG] / base - 1), rel=1e-9)
    assert c["low_pct"] > 0 > c["high_pct"]  # heavier, more fuel
    from vehval.report.sensitivity_page import render_sensitivity_page

    html = render_sensitivity_page(res, "inline")
    assert "no SOC correction" in html and "SOC-corrected" not in html


def test_parallel_hybrid_tornado_reads_its_own_blocks(tmp_path):
    """Defect 3: the parallel hybrid's blocks (motor) and its variants (no power-split
    batch): each end is the SOC-corrected figure from the charge-balanced base's SOC."""
    p = _with_uncertainty(tmp_path, "insight_2000",
                          {"body": {"aux_power_w": {"range": [0.0, 300.0]}},
                           "motor": {"loss_w": {"scale": [0.9, 1.1]}}})
    res = sensitivity(p, ["ece15"], dt=1.0)
    rows = {r["key"]: r for r in res["parameters"]}
    assert set(rows) == {"body.aux_power_w", "motor.loss_w"}
    veh = load_vehicle(p)
    soc0 = res["base"]["ece15"]["soc_initial"]
    high = simulate(veh.with_overrides({"body.aux_power_w": 300.0}), "ece15", dt=1.0,
                    soc_initial=soc0).summary[MPG]
    assert rows["body.aux_power_w"]["cycles"]["ece15"]["high_mpg"] == pytest.approx(high)
    assert rows["body.aux_power_w"]["cycles"]["ece15"]["high_pct"] < 0


def test_road_load_on_conventional_and_parallel(capsys):
    """Defects 2 and 3: KeyError 'soc_initial' (Cruze), AttributeError 'mg2' (Insight)."""
    plain = simulate("cruze_diesel_2014", "ece15", dt=1.0).summary[PLAIN_MPG]
    balanced = simulate("insight_2000", "ece15", dt=1.0, charge_balance=True).summary[MPG]
    for name, base in (("cruze_diesel_2014", plain), ("insight_2000", balanced)):
        rc = main(["sensitivity", "--vehicle", name, "--road-load", "--cycles", "ece15",
                   "--dt", "1", "--json"])
        out = capsys.readouterr()
        assert rc == 0, out.err
        r = json.loads(out.out)["derivatives"]["cycles"]["ece15"]
        assert r["mpg"] == pytest.approx(base, rel=1e-12)
        assert all(v is not None for v in r["elasticity"].values()), r  # every one finite
        assert (r["soc_initial"] is None) == (name == "cruze_diesel_2014")  # no battery
        if name == "cruze_diesel_2014":
            assert r["elasticity"]["body.mass_kg"] < 0 and r["per_100_lb_pct"] < 0


@pytest.mark.parametrize("road_load", [False, True])
def test_battery_electric_is_refused_in_one_line(capsys, road_load):
    p = str(_vehicles_dir() / "bev" / "nissan_leaf_2016.yaml")
    err = _one_line_error(capsys, ["sensitivity", "--vehicle", p, "--cycles", "ece15",
                                   "--dt", "1", *(["--road-load"] if road_load else [])])
    assert "battery_electric" in err and "no fuel" in err


@pytest.mark.parametrize("params", [",", " , ", ""])
def test_empty_parameter_list_is_refused(capsys, params):
    """Defect 4: `--params ,` printed an empty tornado with exit 0."""
    err = _one_line_error(capsys, ["sensitivity", "--cycles", "ece15", "--params", params])
    assert err.startswith("vehval: error: --params: give at least one parameter")


def test_no_uncertain_parameter_is_refused(capsys):
    """Defect 5: insight_2000 (no uncertainty) printed an empty table with exit 0."""
    err = _one_line_error(capsys, ["sensitivity", "--vehicle", "insight_2000", "--cycles",
                                   "ece15", "--dt", "1"])
    assert "no parameter carries an uncertainty" in err and "'uncertainty:'" in err


def test_a_cycle_or_parameter_named_twice_runs_once(capsys):
    """Defect 6: `--cycles udds,udds` printed duplicate columns."""
    argv = ["sensitivity", "--cycles", "ece15,ece15", "--params",
            "body.aux_power_w,body.aux_power_w", "--dt", "1"]
    assert main([*argv, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["cycles"] == ["ece15"] and [r["key"] for r in doc["parameters"]] == [
        "body.aux_power_w"]
    assert main(argv) == 0
    (row,) = [ln for ln in capsys.readouterr().out.splitlines() if "aux_power_w" in ln]
    assert len(row.split()) == 3  # key, swing, one low/high pair


def test_monte_carlo_needs_the_results_commands_draws(capsys):
    """Defect 7: `--monte-carlo 1` printed 5/50/95 % of a single draw."""
    from vehval.cli.options import BOUNDS

    assert BOUNDS["mc_sensitivity"].lo == BOUNDS["mc_results"].lo == 100
    err = _one_line_error(capsys, ["sensitivity", "--cycles", "ece15", "--monte-carlo", "1"])
    assert "--monte-carlo 1: must be 0 or within [100, 10000] draws" in err


def test_swing_is_the_largest_change_of_either_end():
    """Defect 8: |high - low| ranked a parameter moving both ends the same way as 0."""
    nan = float("nan")
    assert swing_pct({"udds": {"low_pct": 0.2, "high_pct": 0.2}}) == 0.2
    assert swing_pct({"a": {"low_pct": 0.2, "high_pct": -0.1},
                      "b": {"low_pct": nan, "high_pct": -1.5}}) == 1.5
    assert swing_pct({"a": {"low_pct": nan, "high_pct": nan}}) != swing_pct({})  # both nan


def test_same_way_parameter_ranks_by_its_change(prius):
    res = sensitivity(prius, ["udds"], ["controller.min_on_time_s"], dt=1.0)
    c = res["parameters"][0]["cycles"]["udds"]
    # both ends raise the UDDS figure (+0.2 / +0.2 %): ranked by that, not by their gap
    assert c["low_pct"] > 0 and c["high_pct"] > 0
    assert res["parameters"][0]["swing_pct"] == max(abs(c["low_pct"]), abs(c["high_pct"]))


def test_metric_units_on_screen(capsys, monkeypatch):
    """Defect 9: `--units metric` printed mpg and '%/100 lb'."""
    monkeypatch.setenv(ENV_VAR, "us")  # --units sets it for the run: restored after the test
    argv = ["sensitivity", "--cycles", "ece15", "--params", "body.aux_power_w", "--dt", "1"]
    assert main([*argv, "--json"]) == 0
    mpg = json.loads(capsys.readouterr().out)["base"]["ece15"]["mpg"]
    assert main(["--units", "metric", *argv]) == 0
    out = capsys.readouterr().out
    assert "mpg" not in out
    assert f"base ece15 {L100_PER_MPG / mpg:.2f} L/100 km" in out
    assert main(["--units", "metric", "sensitivity", "--road-load", "--cycles", "ece15",
                 "--dt", "1", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)["derivatives"]["cycles"]["ece15"]
    assert "per_100_lb_pct" in r  # JSON keys do not follow --units
    assert main(["--units", "metric", "sensitivity", "--road-load", "--cycles", "ece15",
                 "--dt", "1"]) == 0
    head, row = capsys.readouterr().out.splitlines()[1:3]
    assert "L/100 km" in head and "%/100 kg" in head and "mpg" not in head
    assert row.split()[1] == f"{L100_PER_MPG / r['mpg']:.2f}"
    assert row.split()[-1] == f"{r['per_100_kg_pct']:+.2f}"
    # 100 kg is 100 / 45.359237 = 2.2046 times 100 lb of test weight
    assert r["per_100_kg_pct"] == pytest.approx(r["per_100_lb_pct"] / 0.45359237, rel=1e-12)


def _pair_rows():
    heavy = dict(mass_kg=1530.9, road_load_a_n=138.5, road_load_b_n_per_mps=3.5,
                 road_load_c_n_per_mps2=0.31)
    light = dict(mass_kg=1474.2, road_load_a_n=76.2, road_load_b_n_per_mps=2.86,
                 road_load_c_n_per_mps2=0.308)
    return [{"procedure": "hwfet", "label": "a", **heavy, "measured_mpg": 60.0,
             "predicted_mpg": 61.0},
            {"procedure": "hwfet", "label": "b", **light, "measured_mpg": 62.0,
             "predicted_mpg": 62.0}]


@pytest.mark.parametrize("units,config", [
    ("us", "b (3250 lb, A 17.13 lbf) vs a (3375 lb, A 31.14 lbf)"),
    ("metric", "b (1474 kg, A 76.2 N) vs a (1531 kg, A 138.5 N)")])
def test_road_load_pairs_in_one_unit_system(capsys, monkeypatch, units, config):
    """Defect 9: the us text read '3250 lb, A 76.2 N'. 1474.2 kg / 0.45359237 = 3250 lb,
    76.2 N / 4.4482216 = 17.13 lbf; the JSON label stays SI."""
    from vehval.cli.commands_sensitivity import _road_load_text

    monkeypatch.setenv(ENV_VAR, units)
    (pair,) = configuration_pairs(_pair_rows())
    assert pair["config"] == "b (1474 kg, A 76.2 N)"
    assert pair["config_mass_kg"] == 1474.2 and pair["reference_road_load_a_n"] == 138.5
    d = {"dt_s": 1.0, "rel_step": 0.05, "cycles": {}}
    _road_load_text({"vehicle": "v", "derivatives": d, "pairs": [pair]})
    assert config in capsys.readouterr().out


def test_model_uncertainty_of_a_parallel_hybrid_runs_its_own_variants(tmp_path):
    """The model uncertainty took the power-split batch for every car with a battery: a
    parallel hybrid with ranges crashed (no 'mg2'). U is now half the swing of its one range
    read as uniform (k = 2): U = 2 * |high - low| / 2 / sqrt(3)."""
    from vehval.sim.model_uncertainty import figure_uncertainty

    p = _with_uncertainty(tmp_path, "insight_2000",
                          {"body": {"aux_power_w": {"range": [0.0, 300.0]}}})
    fu = figure_uncertainty(p, "ece15", dt=1.0)
    res = sensitivity(p, ["ece15"], dt=1.0)
    c = res["parameters"][0]["cycles"]["ece15"]
    expected = 2 * abs(c["high_mpg"] - c["low_mpg"]) / 2 / 3 ** 0.5
    assert fu.u_mpg == pytest.approx(expected, rel=1e-9) and fu.u_mpg > 0
