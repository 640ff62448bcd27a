"""Battery-electric vehicle file and kernel: loading, refusals, energy closure, limits."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from helpers.bev import bev_data
from vehval.errors import ConfigError
from vehval.sim.simulate import ARCHITECTURES, simulate
from vehval.vehicle import BatteryElectricVehicle, load_vehicle


def test_loads_as_battery_electric(bev_file):
    veh = load_vehicle(bev_file)
    assert isinstance(veh, BatteryElectricVehicle)
    assert "battery_electric" in ARCHITECTURES
    assert veh.sources()["motor.loss_w"].startswith("ORNL/TM-2006/423")
    # usable energy of a 24 kWh pack between 5 and 97 % SOC
    assert 19.0 < veh.usable_energy_j() / 3.6e6 < 24.0


@pytest.mark.parametrize("key,block", [("engine", {"speed_rpm": [0, 1]}),
                                       ("gearbox", {"ratios": [3.0]}),
                                       ("controller", {})])
def test_mixed_architecture_refused_naming_the_key(tmp_path, key, block):
    data = bev_data()
    data[key] = block
    path = tmp_path / "mixed.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(ConfigError) as exc:
        load_vehicle(path)
    msg = str(exc.value)
    assert "\n" not in msg
    assert f"key '{key}' belongs to a" in msg and "battery_electric" in msg


def test_unsourced_value_refused(tmp_path):
    data = bev_data()
    del data["charger"]["sources"]["efficiency"]
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(ConfigError, match="charger.*efficiency"):
        load_vehicle(path)


@pytest.mark.parametrize("cycle", ["udds", "hwfet", "us06"])
def test_energy_closure_and_trace(bev_file, cycle):
    res = simulate(bev_file, cycle, dt=0.1)
    s = res.summary
    assert abs(s["energy_balance_rel"]) < 1e-9
    assert abs(s["unmet_energy_j"]) < 1e-3  # rounding only: the pack meets every demand
    assert s["trace_n_miss"] == 0 or cycle == "us06"
    # DC energy = chemical energy - battery I^2 R loss
    assert s["ess_dc_energy_j"] == pytest.approx(s["ess_chem_energy_j"] - s["ess_loss_j"],
                                                 rel=1e-9)
    # SOC follows the charge drawn
    veh = res.vehicle
    q = np.sum(res.test["ess_curr_simu"].values[1:]) * 0.1
    assert s["soc_delta"] == pytest.approx(-q / veh.battery.capacity_c, rel=1e-9)
    assert s["regen_energy_kwh"] > 0
    assert s["mpge"] == pytest.approx(s["distance_m"] / 1609.344
                                      / (s["ac_energy_kwh"] / 33.705), rel=1e-12)


def test_regen_limits(bev_file):
    veh = load_vehicle(bev_file)
    full = simulate(veh, "udds", dt=0.1).summary
    none = simulate(veh, "udds", dt=0.1, **{"regen.driven_axle_share": 1e-6}).summary
    capped = simulate(veh, "udds", dt=0.1, **{"regen.max_power_w": 5000.0}).summary
    assert none["regen_energy_kwh"] < 0.01 * full["regen_energy_kwh"]
    assert none["dc_energy_kwh"] > full["dc_energy_kwh"] * 1.15
    assert none["regen_energy_kwh"] < capped["regen_energy_kwh"] < full["regen_energy_kwh"]
    tm = simulate(veh, "udds", dt=0.1, **{"regen.max_power_w": 5000.0}).test
    p_mech = tm["mot_trq_out_simu"].values * tm["mot_spd_out_simu"].values
    assert p_mech.min() > -5000.0 * 1.1  # at the wheel cap through the reduction


def test_charge_balance_refused(bev_file):
    with pytest.raises(ConfigError, match="charge-depleting"):
        simulate(bev_file, "udds", dt=1.0, charge_balance=True)


def test_motor_peak_power_respected(bev_file):
    res = simulate(bev_file, "us06", dt=0.1, **{"motor.max_power_w": 40_000.0})
    t = res.test
    p = t["mot_trq_out_simu"].values * t["mot_spd_out_simu"].values
    assert p.max() < 40_000.0 * 1.05


def test_simulate_screen_of_a_battery_electric_car_states_its_energy(capsys):
    """`vehval simulate` printed two lines then an internal error (KeyError 'fuel_mass_kg')."""
    import json

    from vehval.cli import main

    args = ["simulate", "--vehicle", "bev/nissan_leaf_2016", "--cycle", "ece15"]
    assert main([*args, "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert main(args) == 0
    out = capsys.readouterr().out
    assert f"AC consumption      {s['ac_kwh_per_100mi']:.2f} kWh/100 mi" in out
    assert f"MPGe                {s['mpge']:.1f}" in out and "fuel" not in out
    assert main(["--units", "metric", *args]) == 0
    assert f"AC consumption      {s['ac_kwh_per_100km']:.2f} kWh/100 km" in capsys.readouterr().out
    # the shipped name without its folder is pointed to it
    assert main(["simulate", "--vehicle", "nissan_leaf_2016", "--cycle", "ece15"]) == 2
    assert "(did you mean bev/nissan_leaf_2016?)" in capsys.readouterr().err
