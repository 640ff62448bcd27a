"""Calculation engine, QA level 3 and signal selection on hand-constructed tests."""

import numpy as np
import pytest

from vehval.equations.calc import compute, load_calculations
from vehval.errors import ConfigError
from vehval.qa.findings import Kind
from vehval.qa.level3 import run_checks, run_level3
from vehval.qa.pipeline import run_qa
from vehval.qa.select import select_signals
from vehval.test import Signal, Test

from .helpers import CONSTANTS, NR, NS, make_test


def test_calc_computes_power_split_chain_and_explains_missing():
    test = make_test(seed=31, noise=False)
    res = compute(test, None, "power_split", dict(CONSTANTS))
    # ring/sun teeth come only from a vehicle: Willis relations are explained, not computed
    assert "gen_spd_out_calc" not in res.computed
    why = " ".join(res.not_computed["gen_spd_out_calc"])
    assert "ring_teeth" in why and "no vehicle given" in why
    assert "veh_frc_in_calc" in res.computed and "whl_spd_calc" in res.computed
    # with the teeth, the chain reaches the generator speed and the motor torque
    test2 = make_test(seed=31, noise=False)
    res2 = compute(test2, {"planetary": {"ring_teeth": NR, "sun_teeth": NS}}, "power_split",
                   dict(CONSTANTS))
    for name in ("gen_spd_out_calc", "mot_trq_out_calc", "pg_trq_ring_calc", "mot_spd_out_calc"):
        assert name in res2.computed, res2.not_computed.get(name)
    assert res2.computed["mot_spd_out_calc"]["inputs"] == {"whl_spd": "whl_spd_calc"}
    # noise-free Willis: generator speed reproduced to the interpolation error of the 1 Hz OBD
    g_meas = test2["gen_spd_out_obd_test"]
    g_calc = test2["gen_spd_out_calc"].at(g_meas.time)
    ok = np.isfinite(g_calc)
    assert np.max(np.abs(g_calc[ok] - g_meas.values[ok])) < 1.0       # rad/s


def test_calc_no_circular_self_confirmation():
    t = np.arange(0, 100, 0.1)
    test = Test([Signal.standard("veh_spd_test", t, 10 + np.sin(t), source="dyno")])
    res = compute(test, None, "conventional", {"wheel_radius_m": 0.3})
    assert "whl_spd_calc" in res.computed
    assert "veh_spd_calc" not in res.computed
    assert any("circular" in r for r in res.not_computed["veh_spd_calc"])


def test_missing_signal_reason():
    t = np.arange(0, 10, 0.1)
    test = Test([Signal.standard("veh_spd_test", t, t, source="dyno")])
    res = compute(test, None, "conventional", {})
    assert any("fuel_rate missing" in r for r in res.not_computed["fuel_pwr_calc"])


def test_bad_calculation_file(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("calculation_version: 1\nname: x\nrelations:\n  - {output: veh_spd, expr: 'os.system(1)'}\n")
    with pytest.raises(ConfigError, match="relations\\[0\\]"):
        load_calculations(p)
    p.write_text("calculation_version: 1\nname: x\nrelations:\n  - {output: nope, expr: '1'}\n")
    with pytest.raises(ConfigError, match="nope"):
        load_calculations(p)


def test_level3_table_and_sign_flip_check():
    veh = {"planetary": {"ring_teeth": NR, "sun_teeth": NS}}
    test = make_test(seed=32)
    res = compute(test, veh, "power_split", dict(CONSTANTS))
    rows, found = run_level3(test, res)
    assert found == [], [f.message for f in found]
    frc = [r for r in rows if r.measured == "veh_frc_in_test"][0]
    assert frc.r2 > 0.99 and frc.rel_diff < 0.02
    crow, cf = run_checks(test, res)
    assert cf == [] and crow[0]["r2"] > 0.9
    # reversed current clamp: the electrical balance flags ess_curr_test
    flipped = make_test(seed=32)
    s = flipped["ess_curr_test"]
    flipped.add(Signal.standard(s.name, s.time, -s.values, source="dyno"), replace_existing=True)
    res = compute(flipped, veh, "power_split", dict(CONSTANTS))
    _, cf = run_checks(flipped, res)
    assert [(f.signal, f.kind) for f in cf] == [("ess_curr_test", Kind.SIGN_FLIP)]


def test_level3_detects_torque_drift():
    veh = {"planetary": {"ring_teeth": NR, "sun_teeth": NS}}
    test = make_test(seed=33)
    s = test["eng_trq_out_test"]
    drift = np.clip((s.time - 60) / (s.time[-1] - 60), 0, 1) * 8.0
    test.add(Signal.standard(s.name, s.time, s.values + drift, source="dyno"), replace_existing=True)
    res = compute(test, veh, "power_split", dict(CONSTANTS))
    _, found = run_level3(test, res)
    hit = [f for f in found if f.signal == "eng_trq_out_test"]
    assert hit and hit[0].overlaps(100, 300)


def test_selection_rules_and_user_override():
    test = make_test(seed=34)
    s = test["mot_trq_out_obd_test"]
    test.add(Signal.standard("mot_trq_out_test", s.time, np.zeros(s.time.size), source="obd"))
    res = run_qa(test, {"planetary": {"ring_teeth": NR, "sun_teeth": NS}})
    sel = res.selection
    assert "eng_spd_out_test" in sel.kept and "duplicate of eng_spd_out_test" in sel.dropped["eng_spd_out_obd_test"]
    assert sel.dropped["mot_trq_out_test"].startswith("all_zero")
    assert set(sel.kept) | set(sel.dropped) == {s.name for s in test}
    assert "eng_spd_out_obd_test" not in res.validated and "gen_spd_out_calc" in res.validated
    # the user overrides: keep the OBD engine speed, drop the fuel rate
    test_all = make_test(seed=34)
    res2 = run_qa(test_all)
    sel3 = select_signals(test_all, res2.findings, res2.table2, res2.table3,
                          user_keep=["eng_spd_out_obd_test"], user_drop={"fuel_rate_test": "meter off"})
    assert sel3.kept["eng_spd_out_obd_test"].startswith("kept by the user")
    assert "the user keeps" in sel3.dropped["eng_spd_out_test"]
    assert sel3.dropped["fuel_rate_test"] == "dropped by the user: meter off"


def test_disagreeing_sources_choose_the_one_matching_calc():
    veh = {"planetary": {"ring_teeth": NR, "sun_teeth": NS}}
    test = make_test(seed=35)
    # the facility engine speed is 10 % off: OBD agrees with Willis, facility does not
    s = test["eng_spd_out_test"]
    test.add(Signal.standard(s.name, s.time, 1.1 * s.values, source="dyno"), replace_existing=True)
    res = run_qa(test, veh)
    assert "eng_spd_out_obd_test" in res.selection.kept, res.selection.to_dict()
    assert "eng_spd_out_test" in res.selection.dropped
