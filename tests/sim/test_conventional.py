"""Conventional powertrain simulation: loading, trace following, energy closure, physics."""

import numpy as np
import pytest
import yaml
from conventional_vehicle import conventional_dict, conventional_vehicle

from vehval.errors import ConfigError
from vehval.sim.conventional_kernel import coupling_pump_speed, select_gear
from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle


def test_architecture_key_dispatches(tmp_path):
    p = tmp_path / "car.yaml"
    p.write_text(yaml.safe_dump(conventional_dict()))
    veh = load_vehicle(p)
    assert veh.architecture == "conventional"
    assert load_vehicle("prius_2004").architecture == "power_split"
    bad = conventional_dict()
    bad["architecture"] = "series"
    p.write_text(yaml.safe_dump(bad))
    with pytest.raises(ConfigError, match="architecture.*series"):
        load_vehicle(p)


def test_shift_lines_must_have_hysteresis(tmp_path):
    d = conventional_dict(**{"gearbox.downshift_speed_mps": [5.0, 4.5, 7.5, 11.0, 15.0]})
    p = tmp_path / "car.yaml"
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(ConfigError, match="gear pair 1-2"):
        load_vehicle(p)


def test_udds_follows_trace_and_closes_energy():
    res = simulate(conventional_vehicle(), "udds", dt=0.1)
    s = res.summary
    # trace followed within the EPA band everywhere
    assert s["trace_max_miss_mps"] == 0.0
    # every joule of fuel lands in a sink: closure to 1e-9 of the fuel energy (round-off)
    assert abs(s["energy_balance_rel"]) < 1e-9
    # plausible small-car diesel figures on UDDS: 4-9 L/100 km, 6 gears used
    assert 4.0 < s["fuel_consumption_l_per_100km"] < 9.0
    gears = res.test["gb_gear_simu"].values
    assert set(np.unique(gears)) == {1, 2, 3, 4, 5, 6}
    # engine never below idle while driving, never above max
    w = res.test["eng_spd_out_simu"].values
    assert w.min() >= 800 * np.pi / 30 * 0.999 and w.max() < 4500 * np.pi / 30


def test_locked_gear_engine_speed_is_ratio_times_wheel_speed():
    res = simulate(conventional_vehicle(), "hwfet", dt=0.1)
    t = res.test
    g = t["gb_gear_simu"].values.astype(int)
    v = t["veh_spd_simu"].values
    w = t["eng_spd_out_simu"].values
    ratios = np.array([4.0, 2.4, 1.55, 1.15, 0.86, 0.68]) * 3.0
    steady = (g == 6) & (v > 20)
    steady[1:] &= g[:-1] == 6
    expected = ratios[g[steady] - 1] * v[steady] / 0.31
    # engine speed follows the gear with time constant shift_time / 2: 1 % once settled
    np.testing.assert_allclose(w[steady][20:], expected[20:], rtol=0.01)


def test_coupling_and_gear_selection_hand_cases():
    # T = k w (w - wt): k = 0.01, wt = 100, T = 20 -> w = (100 + sqrt(1e4 + 8000)) / 2
    assert coupling_pump_speed(100.0, 20.0, 0.01) == pytest.approx((100 + np.sqrt(18000)) / 2)
    up0, up1 = np.array([4.0, 7.0]), np.array([7.0, 12.0])
    dn0, dn1 = np.array([2.0, 4.5]), np.array([4.0, 8.0])
    assert select_gear(1, 5.0, 0.0, up0, up1, dn0, dn1) == 2      # above the zero-load line
    assert select_gear(1, 5.0, 1.0, up0, up1, dn0, dn1) == 1      # full load holds the gear
    assert select_gear(2, 2.9, 0.5, up0, up1, dn0, dn1) == 1      # below 2 + 0.5 * 2 = 3 m/s
    assert select_gear(2, 3.1, 0.5, up0, up1, dn0, dn1) == 2


def test_packaged_cruze_loads_and_simulates():
    res = simulate("cruze_diesel_2014", "hwfet", dt=0.1)
    s = res.summary
    assert res.vehicle.architecture == "conventional"
    assert s["trace_max_miss_mps"] == 0.0
    assert abs(s["energy_balance_rel"]) < 1e-9
    # a compact diesel on the highway cycle: 3.5-6 L/100 km
    assert 3.5 < s["fuel_consumption_l_per_100km"] < 6.0


def _steady(v_mps: float, seconds: float = 120.0):
    from vehval.cycles import Cycle
    t = np.arange(0.0, seconds + 0.05, 0.1)
    v = np.full(t.size, v_mps)
    if v_mps > 0:
        v[: 300] = np.linspace(0.0, v_mps, 300)   # 30 s run-up, then steady
    return Cycle(name="steady", time_s=t, speed_mps=v, description="hand case")


def test_driveline_drag_loads_the_engine_not_the_roller():
    """At a steady 20 m/s in top gear (locked), the engine delivers road load + drag through
    the gearbox, while the force at the wheels (what a roller measures) is the road load."""
    cyc = _steady(20.0)
    base = simulate(conventional_vehicle(), cyc, dt=0.1).test
    drag = simulate(conventional_vehicle(**{"gearbox.drag_force_n": 80.0,
                                            "gearbox.drag_force_n_per_mps": 1.0}), cyc, dt=0.1)
    t, s = drag.test, drag.summary
    last = slice(-200, None)
    v = t["veh_spd_simu"].values[last]
    rl = 100.0 + 2.0 * v + 0.4 * v * v
    veh = conventional_vehicle()
    assert veh.body.road_load_a_n == 100.0 and veh.body.road_load_c_n_per_mps2 == 0.4
    # roller (wheel) force unchanged: the road load
    np.testing.assert_allclose(t["veh_frc_in_simu"].values[last], rl, rtol=2e-3)
    # engine power up by (80 + 1 v) v / efficiency (gearbox x final drive)
    eff = veh.gearbox.efficiency * veh.driveline.final_drive_efficiency
    dp = t["eng_pwr_out_simu"].values[last] - base["eng_pwr_out_simu"].values[last]
    np.testing.assert_allclose(dp, (80.0 + 1.0 * v) * v / eff, rtol=5e-3)
    assert abs(s["energy_balance_rel"]) < 1e-9


def test_ac_load_at_standstill_is_the_maps_marginal_fuel():
    """Standing with the A/C on: idle fuel + map(idle, T_acc + T_ac) - map(idle, T_acc)."""
    from vehval.sim.maps import interp2
    cyc = _steady(0.0, 60.0)
    veh = conventional_vehicle(**{"engine_control.ac_power_w": 2500.0,
                                  "engine_control.ac_on": True})
    off = conventional_vehicle(**{"engine_control.ac_power_w": 2500.0})
    f_on = simulate(veh, cyc, dt=0.1).test["fuel_rate_simu"].values[-100:]
    f_off = simulate(off, cyc, dt=0.1).test["fuel_rate_simu"].values[-100:]
    w = veh.engine.idle_speed_rpm * np.pi / 30
    acc = veh.engine_control.accessory_power_w + veh.body.aux_power_w
    m = veh.engine.arrays()
    extra = (interp2(m["spd"], m["trq"], m["fuel"], w, (acc + 2500.0) / w)
             - interp2(m["spd"], m["trq"], m["fuel"], w, acc / w))
    np.testing.assert_allclose(f_off, veh.engine_control.idle_fuel_rate_g_per_s * 1e-3)
    np.testing.assert_allclose(f_on, f_off + extra, rtol=1e-9)
    assert extra > 0


def test_ac_on_costs_fuel_while_driving_and_is_not_a_parameter():
    on = conventional_vehicle(**{"engine_control.ac_power_w": 2000.0, "engine_control.ac_on": True})
    off = conventional_vehicle(**{"engine_control.ac_power_w": 2000.0})
    f_on = simulate(on, "udds", dt=0.1).summary["fuel_mass_kg"]
    f_off = simulate(off, "udds", dt=0.1).summary["fuel_mass_kg"]
    # 2 kW over 1369 s at an engine efficiency of 20-45 %: 0.14-0.32 kg more
    assert 0.14 < f_on - f_off < 0.32
    assert "engine_control.ac_on" not in on.parameters()
    assert "engine_control.ac_power_w" in on.parameters()
