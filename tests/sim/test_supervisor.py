"""The engine rule is one function: the replay over the loop's own inputs gives the loop's
own engine commands, step for step (exact: same compiled code, same numbers)."""

from __future__ import annotations

import numpy as np

from vehval.sim.control import ENG_ON, ENG_ON_MINTIME
from vehval.sim.simulate import simulate
from vehval.sim.supervisor import RULE_KEYS, replay_rule, rule_params, rule_vector


def _sig(res, name):
    return res.test[f"{name}_simu"].values


def test_replay_reproduces_the_loops_engine_commands():
    res = simulate("prius_2004", "udds", dt=1.0)
    veh = res.vehicle
    c = veh.controller
    p_wh = _sig(res, "drv_pwr_demand")[1:]  # demand of step i is recorded at row i + 1
    v = _sig(res, "veh_spd")[:-1]  # speed and SOC at the start of step i
    soc = _sig(res, "ess_soc")[:-1]
    pdis_av = np.maximum(_sig(res, "ess_pwr_lim_dis")[:-1] - c.battery_discharge_margin_w, 0.0)
    prm = rule_vector(rule_params(veh))
    cmd = replay_rule(p_wh, v, soc, pdis_av, veh.body.aux_power_w, 1.0, prm, False)
    state = _sig(res, "eng_ctrl_state")
    loop_on = (state == ENG_ON) | (state == ENG_ON_MINTIME)
    assert loop_on.any() and (~loop_on).any()  # the cycle switches the engine
    np.testing.assert_array_equal(cmd[1:], loop_on[1:-1])  # replay step i = loop row i


def test_rule_without_a_vehicle_is_the_reference_file_with_soc_terms_off():
    p = rule_params()
    assert set(p) == set(RULE_KEYS)
    assert p["soc_engine_on"] == 0.0 and p["soc_gain_w"] == 0.0
    assert p["engine_on_power_w"] > p["engine_off_power_w"] > 0.0
