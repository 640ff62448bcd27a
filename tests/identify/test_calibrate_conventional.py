"""Calibration of a conventional model recovers a parameter that generated a virtual test."""

import json

import pytest

from vehval.cli import main
from vehval.cycles import load_cycle
from vehval.identify import load_traces
from vehval.identify.calibrate import calibrate_conventional
from vehval.synth.conventional import make_conventional_test
from vehval.vehicle import load_vehicle

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def virtual(tmp_path_factory):
    truth = load_vehicle("cruze_diesel_2014").with_overrides({"gearbox.efficiency": 0.88})
    out = {}
    for cyc in ("udds", "hwfet"):
        d = tmp_path_factory.mktemp(cyc)
        info = make_conventional_test(truth, load_cycle(cyc), seed=5, outdir=d)
        out[cyc] = (info["files"][0], info["template"])
    return out


def test_efficiency_recovered_and_holdout_improves(virtual):
    start = load_vehicle("cruze_diesel_2014")           # gearbox.efficiency 0.93
    tune = load_traces([virtual["udds"][0]], virtual["udds"][1])
    hold = load_traces([virtual["hwfet"][0]], virtual["hwfet"][1])
    res = calibrate_conventional(start, tune, ["gearbox.efficiency"], hold)
    # generated with 0.88: found within 0.01 (the bench noise and lag do not bias the total)
    assert res.best["gearbox.efficiency"] == pytest.approx(0.88, abs=0.01)
    rows = {r["role"]: r for r in res.tests}
    assert abs(rows["tune"]["error_rel_after"]) < 0.005
    assert abs(rows["holdout"]["error_rel_after"]) < abs(rows["holdout"]["error_rel_before"])
    src = res.vehicle.gearbox.sources["efficiency"]
    assert src.startswith(f"calibrated by vehval calibrate on tests {tune[0].test_id} on ")
    assert "sum of squared relative fuel errors" in src and "bounded Powell" in src
    assert f"held out {hold[0].test_id}" in src


def test_cli_calibrate_conventional_writes_both_files(virtual, tmp_path, capsys):
    f, tpl = virtual["udds"]
    out = tmp_path / "cal"
    rc = main(["calibrate", str(f), "-t", str(tpl), "--vehicle", "cruze_diesel_2014",
               "--params", "gearbox.efficiency", "--holdout", str(virtual["hwfet"][0]),
               "-o", str(out), "--json"])
    assert rc == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["architecture"] == "conventional"
    assert [r["role"] for r in doc["tests"]] == ["tune", "holdout"]
    assert load_vehicle(out / "vehicle_calibrated.yaml").architecture == "conventional"


def test_cli_says_a_bound_hit_and_the_held_out_mean(virtual, tmp_path, capsys):
    """A car that needs more than 100 % gearbox efficiency to match (it has no accessory load,
    the start vehicle 300 W): the tuned value ends on its bound, which the table says; the
    tuning tests are marked in sample and each role's mean |error| is given before -> after."""
    truth = load_vehicle("cruze_diesel_2014").with_overrides(
        {"gearbox.efficiency": 1.0, "engine_control.accessory_power_w": 0.0})
    info = make_conventional_test(truth, load_cycle("udds"), seed=6, outdir=tmp_path / "t")
    rc = main(["calibrate", str(info["files"][0]), "-t", str(info["template"]),
               "--vehicle", "cruze_diesel_2014", "--params", "gearbox.efficiency",
               "--holdout", str(virtual["hwfet"][0]), "-o", str(tmp_path / "cal")])
    out = capsys.readouterr().out
    assert rc == 0
    lines = out.splitlines()
    eff = next(line for line in lines if line.startswith("gearbox.efficiency:"))
    assert "(at its upper bound 1: not identified" in eff, out
    assert any("(tune, in sample)" in line for line in lines)
    note = next(line for line in lines if line.startswith("held-out: 1 tests, mean |fuel error|"))
    assert "; in-sample (a fit, not a prediction): 1 tests, mean |fuel error|" in note


def test_holdout_the_start_vehicle_was_identified_on_is_in_sample():
    """A --holdout test that is one of the start vehicle's identification tests is a fit, as
    `vehval predict` marks it: before, the summary counted it as held out."""
    import numpy as np

    from vehval.identify import trace_from_test
    from vehval.identify.calibrate_stage import _lines
    from vehval.test import Signal, TestMeta
    from vehval.test import Test as VTest

    def trace(tid):
        t = np.arange(0.0, 200.0, 0.1)
        v = np.clip(10 * np.sin(np.pi * t / 100.0), 0, None)
        test = VTest(meta=TestMeta(test_id=tid, files=[f"{tid}.txt"]))
        test.add(Signal.standard("veh_spd_test", t, v))
        test.add(Signal.standard("veh_frc_in_test", t, 200 + 1500 * np.gradient(v, t)))
        test.add(Signal.standard("fuel_rate_test", t, 1e-3 * (0.2 + 0.1 * v)))
        test.add(Signal.standard("eng_spd_out_test", t, 90 + 10 * v))
        return trace_from_test(test)

    veh = load_vehicle("cruze_diesel_2014")     # identified on 61410013 and 61410004
    res = calibrate_conventional(veh, [trace("tune_run")], ["gearbox.efficiency"],
                                 [trace("61410013 Test Data"), trace("other_run")], maxiter=1)
    assert [r["in_sample"] for r in res.tests] == [True, True, False]
    lines = _lines(res)
    assert any(s.startswith("61410013 Test Data (holdout, in sample: the start vehicle was "
                            "identified on it)") for s in lines)
    assert any(s.startswith("held-out: 1 tests") and "in-sample (a fit, not a prediction): "
               "2 tests" in s for s in lines), lines
