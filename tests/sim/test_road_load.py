"""Fixed-loss audit and the fuel economy's derivative with respect to weight and road load."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vehval.cycles import Cycle
from vehval.sim.loss_audit import fixed_loss_audit, no_load_loss_w
from vehval.sim.sensitivity import (
    configuration_pairs,
    load_derivatives,
    tractive_energy_j,
)
from vehval.vehicle import load_vehicle


def _cycle(t, v) -> Cycle:
    return Cycle(name="test", time_s=np.asarray(t, float), speed_mps=np.asarray(v, float))


def test_tractive_energy_by_hand():
    # 20 m/s held 100 s: (A + B v + C v^2) v T
    hold = _cycle([0, 100], [20, 20])
    e = tractive_energy_j(hold, 1500, 100.0, 3.0, 0.3)
    assert e == pytest.approx((100 + 3 * 20 + 0.3 * 400) * 20 * 100, rel=1e-12)
    # a stop from 20 m/s in 2 s with these loads: the inertia pays the road load, no work
    stop = _cycle([0, 2], [20, 0])
    assert tractive_energy_j(stop, 1500, 100.0, 3.0, 0.3) == 0.0
    # every load x k: tractive energy x k (the positive part of a scaled force)
    cyc = "udds"
    e1 = tractive_energy_j(cyc, 1500, 100.0, 3.0, 0.3)
    assert tractive_energy_j(cyc, 1650, 110.0, 3.3, 0.33) == pytest.approx(1.1 * e1, rel=1e-12)


def test_configuration_pairs_elasticity():
    """Figures in inverse proportion to the tractive energy have elasticity 1 exactly."""
    heavy = dict(mass_kg=1530.9, road_load_a_n=138.5, road_load_b_n_per_mps=3.5,
                 road_load_c_n_per_mps2=0.31)
    light = dict(mass_kg=1474.2, road_load_a_n=76.2, road_load_b_n_per_mps=2.86,
                 road_load_c_n_per_mps2=0.308)
    e_h = tractive_energy_j("hwfet", *heavy.values())
    e_l = tractive_energy_j("hwfet", *light.values())
    rows = [{"procedure": "hwfet", "label": "a", **heavy, "measured_mpg": 60.0,
             "predicted_mpg": 61.0},
            {"procedure": "hwfet", "label": "b", **light, "measured_mpg": 60.0 * e_h / e_l,
             "predicted_mpg": 61.0},
            {"procedure": "sc03", "label": "b", **light, "measured_mpg": 1.0,
             "predicted_mpg": 1.0}]
    (p,) = configuration_pairs(rows)
    assert p["procedure"] == "hwfet" and p["reference"] == "a (1531 kg, A 138.5 N)"
    assert p["tractive_change_pct"] == pytest.approx(100 * (e_l / e_h - 1), rel=1e-12)
    assert p["measured_elasticity"] == pytest.approx(1.0, rel=1e-12)
    assert p["predicted_elasticity"] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.slow
def test_load_derivatives_signs_and_sum():
    d = load_derivatives("prius_2004", ["hwfet"], dt=1.0)
    r = d["cycles"]["hwfet"]
    e = r["elasticity"]
    # more weight or road load never improves fuel economy; on a cruise (little braking to
    # recover) the whole-load elasticity stays below 1
    assert all(e[k] < 0 for k in e), e
    assert -1.0 < e["all"] < -0.3
    # the parts add up to the whole (linear over +-5 %); tolerance: curvature of the
    # hybrid's operating points over +-5 % of load
    parts = sum(v for k, v in e.items() if k != "all")
    assert parts == pytest.approx(e["all"], abs=0.05)
    # HWFET is a cruise: the weight matters less than the coast-down terms together
    assert abs(e["body.mass_kg"]) < abs(e["body.road_load_c_n_per_mps2"]
                                        + e["body.road_load_b_n_per_mps"]
                                        + e["body.road_load_a_n"])


def test_fixed_loss_audit_items():
    veh = load_vehicle("prius_2004")
    a = fixed_loss_audit(veh, "ece15", dt=0.5)
    items = {r["key"]: r for r in a["items"]}
    assert set(items) == {"accessories", "engine_start_idle_fuel", "engine_stop",
                          "engine_motoring", "mg1_no_load", "mg2_no_load",
                          "battery_self_discharge"}
    assert all(r["source"] for r in a["items"])
    # accessories: the constant load over the cycle's duration, one step tolerance
    from vehval.cycles import load_cycle

    dur = float(load_cycle("ece15").time_s[-1])
    assert items["accessories"]["energy_j"] == pytest.approx(veh.body.aux_power_w * dur,
                                                            abs=veh.body.aux_power_w * 1.0)
    # the ORNL-derived 2004 machines have a standby loss at zero torque (c0 + spin terms)
    assert no_load_loss_w(veh, "mg2", np.array([0.0]))[0] > 0
    assert items["mg2_no_load"]["energy_j"] > 0 and items["mg1_no_load"]["energy_j"] > 0
    sweep = a["load_sweep"]
    assert np.all(np.diff(sweep["fuel_energy_j"]) > 0)  # more load, more fuel
    assert 0 < sweep["load_independent_share"] < 0.6
    assert sweep["elasticity"] == pytest.approx(1 - sweep["load_independent_share"], rel=1e-9)
    json.dumps(a)  # plain JSON


def test_cli_road_load_needs_both_list_and_selector(capsys):
    from vehval.cli import main

    rc = main(["sensitivity", "--vehicle", "prius_2016", "--road-load", "--tests",
               "model=PRIUS,year=2016"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "--epa" in err and len(err.splitlines()) == 1


def test_cli_road_load_json_and_output(tmp_path, capsys):
    from vehval.cli import main

    rc = main(["sensitivity", "--road-load", "--cycles", "ece15", "--dt", "1", "--json",
               "-o", str(tmp_path / "rl")])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    r = doc["derivatives"]["cycles"]["ece15"]
    assert doc["vehicle"] == "prius_2004" and "pairs" not in doc
    assert set(r["elasticity"]) == {"body.mass_kg", "body.road_load_a_n",
                                    "body.road_load_b_n_per_mps",
                                    "body.road_load_c_n_per_mps2", "all"}
    assert r["tractive_energy_j"] > 0 and r["per_100_lb_pct"] < 0
    assert json.loads((tmp_path / "rl" / "road_load.json").read_text()) == doc


def test_cli_default_step_is_epa_validates(capsys):
    """`vehval sensitivity` ran at 1 s by default where `vehval epa validate` and the docs'
    tables use 0.2 s (the 2016 Prius's UDDS weight elasticity read -0.326, the docs -0.288):
    both modes now default to 0.2 s."""
    import inspect

    from vehval.cli import main
    from vehval.cli.commands_epa_validate import validate_cmd

    validate_dt = inspect.signature(validate_cmd).parameters["dt"].default.default
    assert main(["sensitivity", "--road-load", "--cycles", "ece15", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["derivatives"]["dt_s"] == validate_dt == 0.2
    assert main(["sensitivity", "--cycles", "ece15", "--params", "body.aux_power_w",
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["dt_s"] == 0.2
