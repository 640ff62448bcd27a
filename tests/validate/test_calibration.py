"""Validation of a perturbed Prius and calibration back to its true parameters."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vehval.errors import ConfigError
from vehval.validate import ladder, validate_test
from vehval.validate.calibration import calibrate, default_bounds, start_values
from vehval.validate.conditions import vehicle_variant
from vehval.vehicle import load_vehicle

from .helpers import CONSTANTS, HOLDOUT_CYCLES, TRUTH, TUNE_CYCLES


def test_validation_of_unperturbed_model_shows_the_differences(virtual_tests, nominal):
    # the nominal model against every virtual test: 8 kW engine-on power (true 11 kW) but
    # also 100 W less accessory load and 3 points more final-drive efficiency than the car
    comps = {c: validate_test(t, nominal, dt=1.0).comparison for c, t in virtual_tests.items()}
    fuel = {c: abs(v.fuel_error) for c, v in comps.items()}
    soc = {c: abs(v.soc_final_error) for c, v in comps.items()}
    # measured: fuel 3.7 / 2.8 / 10.1 / 6.9 %, final SOC 5.5 / 3.0 / 5.3 / 4.4 % (Japan
    # 10-15, HWFET, UDDS, NEDC): beyond the 2 % band on every cycle in one or the other
    assert all(max(fuel[c], soc[c]) > 0.02 for c in comps), (fuel, soc)
    assert fuel["udds"] > 0.05  # the model burns clearly less than the perturbed car
    c0 = comps["japan1015"]
    assert c0.fuel_error < 0 and c0.on_agreement < 0.95
    assert c0.starts.n_sim != c0.starts.n_test or c0.starts.matched_share < 1.0
    test = virtual_tests["japan1015"]
    # with the true parameters the replay of the test's own conditions is exact to
    # discretisation noise (same model, same dt): 0.1 % fuel, 0.01 SOC points
    v1 = validate_test(test, nominal, dt=1.0, overrides=TRUTH)
    c1 = v1.comparison
    assert abs(c1.fuel_error) < 1e-3 and abs(c1.soc_delta_error) < 1e-4
    assert c1.on_agreement == 1.0 and c1.starts.matched_share == 1.0
    assert c1.signals["eng_spd_out"]["r2"] > 0.999
    res = ladder([c0, c1])
    e0, e1 = res.entries
    assert e1.passed  # the true parameters are within the default 5 %
    assert e0.passed == (e0.errors["fuel_pct"] <= 5.0 and e0.errors["soc_pct"] <= 5.0)
    strict = ladder([c0, c1], {"fuel_pct": 2.0, "soc_pct": 2.0})
    assert not strict.entries[0].passed and strict.entries[1].passed
    v0 = validate_test(test, nominal, dt=1.0)
    payload = v0.payload()
    assert payload["tables"][0]["rows"] and payload["figures"]
    json.dumps(v0.to_dict())  # JSON-ready (NaN -> None)
    assert v0.conditions.overrides["body.mass_kg"] == 1295.0


#: Recovery tolerances (relative). Thresholds only matter where the demand crosses them, so
#: at dt = 1 s the objective is flat over a band of engine-on powers (about a per cent on
#: these two cycles); the SOC gain acts through the SOC trajectory and the accessory load
#: through the battery current (1.9 A at standstill), both a little less sharply than the
#: regen share (every braking) and the final-drive efficiency (every propelling and
#: regenerating step). Measured (40 generations, the default): +0.42 %, -0.25 %, -0.23 %,
#: -0.5 %, -0.03 % (20 generations stopped at 1.4e-3 of the start objective, -6.9 % on-power).
RECOVERY_TOL = {"controller.engine_on_power_w": 0.03, "controller.soc_gain_w": 0.02,
                "controller.regen_fraction_max": 0.01, "body.aux_power_w": 0.02,
                "driveline.final_drive_efficiency": 0.002}


@pytest.mark.slow
def test_calibration_recovers_controller_and_component_parameters(virtual_tests, nominal, tmp_path):
    tune = [virtual_tests[c] for c in TUNE_CYCLES]
    hold = [virtual_tests[c] for c in HOLDOUT_CYCLES]
    res = calibrate(tune, nominal, list(TRUTH), holdout_tests=hold, dt=1.0, seed=0)
    assert res.method.startswith("differential evolution (traces objective")
    for name, true in TRUTH.items():
        assert abs(res.best[name] - true) / true < RECOVERY_TOL[name], (name, res.best[name], true)
    assert res.objective_best < 1e-3 * res.objective_start
    for tid in res.tests + res.holdout:
        after = res.after[tid]
        # acceptance: fuel and final SOC within 2 % (measured: <= 0.3 % and <= 0.44 %)
        assert after["fuel_pct"] < 2.0 and after["soc_pct"] < 2.0, (tid, after)
    # the nominal model was clearly off on both held-out cycles
    assert min(res.before[t]["fuel_pct"] for t in res.holdout) > 2.0
    assert res.n_simulations >= res.n_evaluations  # one simulation per test per evaluation

    path = res.write_vehicle(tmp_path / "vehicle_calibrated.yaml")
    veh = load_vehicle(path)
    for name in TRUTH:
        blk, key = name.split(".")
        assert getattr(getattr(veh, blk), key) == pytest.approx(res.best[name])
        src = getattr(veh, blk).sources[key]
        assert src.startswith("calibrated by vehval calibrate on tests virtual_japan1015, virtual_hwfet")
        assert "objective" in src and "held out virtual_udds, virtual_nedc" in src
    assert veh.controller.sources["soc_target"] == nominal.controller.sources["soc_target"]
    assert veh.body.sources["mass_kg"] == nominal.body.sources["mass_kg"]
    json.dumps(res.to_dict())


@pytest.mark.slow
def test_batch_mode_calibration(virtual_tests, nominal):
    # the fast summary-only search on the three controller parameters, the component
    # parameters at their true values: the end-of-test quantities pin these well at dt = 1 s
    # (measured within 0.9 %), held-out errors inside the 2 % band
    base = vehicle_variant(nominal, {k: v for k, v in TRUTH.items() if not k.startswith("controller.")})
    names = [k for k in TRUTH if k.startswith("controller.")]
    res = calibrate([virtual_tests[c] for c in TUNE_CYCLES], base, names, mode="batch",
                    holdout_tests=[virtual_tests["udds"]], dt=1.0, seed=0)
    assert "batch objective" in res.method
    for name in names:
        assert abs(res.best[name] - TRUTH[name]) / TRUTH[name] < 0.03, (name, res.best[name])
    assert res.after["virtual_udds"]["fuel_pct"] < 2.0 and res.after["virtual_udds"]["soc_pct"] < 2.0


def test_calibration_inputs_checked(virtual_tests, nominal):
    with pytest.raises(ConfigError, match="unknown"):
        calibrate([virtual_tests["hwfet"]], nominal, ["controller.no_such_thing"], maxiter=1)
    with pytest.raises(ConfigError, match="mode"):
        calibrate([virtual_tests["hwfet"]], nominal, ["engine_on_power_w"], mode="fast", maxiter=1)
    with pytest.raises(ConfigError, match="bounds"):
        calibrate([virtual_tests["hwfet"]], nominal, ["engine_on_power_w"],
                  bounds={"controller.engine_on_power_w": (5.0, 1.0)}, maxiter=1)
    assert start_values({"controller": {"engine_on_power_w": 9000.0, "note": "x"}}) == {
        "controller.engine_on_power_w": 9000.0}
    lo, hi = default_bounds(nominal, "controller.regen_fraction_max", 0.9)
    assert lo == pytest.approx(0.45) and hi == 1.0  # clipped to the field's le=1
    with pytest.raises(ConfigError):
        vehicle_variant(nominal, {"controller.engine_off_speed_mps": 30.0})  # off > on speed
    v = vehicle_variant(nominal, {"engine_on_power_w": 9000.0})
    assert v.controller.engine_on_power_w == 9000.0 and nominal.controller.engine_on_power_w == 8000.0
    assert np.array_equal(v.best_line[0], nominal.best_line[0])


def test_holdout_guard_refuses_a_worse_holdout():
    """Reported: calibration on clean virtual tests made held-out fuel worse (UDDS 0.60 ->
    1.23 %, NEDC 0.43 -> 0.71 %); such a tuning is now refused."""
    from vehval.validate.calibration import holdout_worse

    before = {"udds": {"fuel_pct": 0.60, "soc_pct": 0.1}, "nedc": {"fuel_pct": 0.43, "soc_pct": 0.1}}
    after = {"udds": {"fuel_pct": 1.23, "soc_pct": 0.1}, "nedc": {"fuel_pct": 0.71, "soc_pct": 0.1}}
    why = holdout_worse(before, after, ["udds", "nedc"])
    assert "udds: fuel 0.60 -> 1.23 %" in why and "nedc: fuel 0.43 -> 0.71 %" in why
    assert holdout_worse(after, before, ["udds", "nedc"]) == ""      # better: kept
    assert holdout_worse(before, after, []) == ""                     # nothing held out


def test_calibration_on_clean_tests_never_makes_the_holdout_worse(nominal):
    """Virtual tests of the nominal car itself: the start values are right, so any tuning
    can only fit noise; the held-out fuel error must not grow."""
    from vehval.sim.simulate import simulate
    from vehval.validate.calibration import HOLDOUT_TOL_POINTS, calibrate

    from .helpers import sim_as_test

    def clean(cyc):
        r = simulate(nominal, cyc, dt=1.0, soc_initial=0.6)
        return sim_as_test(r.test, f"clean_{cyc}", cyc, CONSTANTS)

    res = calibrate([clean("japan1015")], nominal, ["body.aux_power_w", "controller.engine_on_power_w"],
                    holdout_tests=[clean("udds")], dt=1.0, popsize=3, maxiter=3, seed=1,
                    polish=False)
    b, a = res.before["clean_udds"], res.after["clean_udds"]
    assert abs(a["fuel_pct"]) <= abs(b["fuel_pct"]) + HOLDOUT_TOL_POINTS + 1e-9, (b, a, res.notes)
    if res.rejected:
        assert res.best == res.start and "over-fitting guard" in res.notes[-1]


def test_calibration_marks_in_sample_and_summarises_held_out_apart(nominal):
    from vehval.validate.calibration import CalibrationResult

    errs = {"a": {"fuel_pct": 4.0, "soc_pct": 1.0}, "b": {"fuel_pct": 2.0, "soc_pct": 1.0},
            "c": {"fuel_pct": 6.0, "soc_pct": 3.0}}
    after = {k: {"fuel_pct": v["fuel_pct"] / 2, "soc_pct": v["soc_pct"]} for k, v in errs.items()}
    res = CalibrationResult(
        parameters=["controller.soc_gain_w"], start={"controller.soc_gain_w": 1.0},
        bounds={"controller.soc_gain_w": (0.5, 2.0)}, best={"controller.soc_gain_w": 1.5},
        objective_start=1.0, objective_best=0.5, tests=["a"], holdout=["b", "c"],
        before=errs, after=after, n_evaluations=1, n_simulations=1, elapsed_s=0.0,
        method="grid", dt=1.0, vehicle=nominal, prior={"c": ["engine.warmup_fuel_fraction"]})
    # c is held out of this tuning but the start vehicle was fitted on it: in-sample
    assert [res.in_sample(t) for t in ("a", "b", "c")] == [True, False, True]
    assert [r[-1] for r in res.rows()] == ["in-sample", "held-out", "in-sample"]
    assert res.rows()[2][1].startswith("held out (in-sample")
    st, ins = res.sample_stats(), res.sample_stats(in_sample=True)
    assert st["tests"] == ["b"] and st["fuel_pct_before"] == 2.0 and st["fuel_pct_after"] == 1.0
    assert ins["tests"] == ["a", "c"] and ins["fuel_pct_before"] == 5.0
    d = res.to_dict()
    assert d["in_sample"] == {"a": True, "b": False, "c": True}
    assert d["stats"]["n_tests"] == 1 and d["stats_in_sample"]["n_tests"] == 2
    assert "held-out: 1 tests, mean |fuel error| 2.00 -> 1.00 %" in d["tables"][1]["note"]


def test_prior_calibration_test_matched_by_the_one_rule(nominal):
    """A held-out test the start vehicle names as ``61410013 Test Data`` is in-sample when
    its id is spelled ``61410013_Test_Data`` (a batch's id of the same file): the marking goes
    through :func:`vehval.calibration.provenance.same_test`, not an exact string match."""
    from vehval.validate.calibration import CalibrationResult

    errs = {t: {"fuel_pct": 2.0, "soc_pct": 1.0} for t in ("a", "61410013_Test_Data")}
    res = CalibrationResult(
        parameters=["controller.soc_gain_w"], start={"controller.soc_gain_w": 1.0},
        bounds={"controller.soc_gain_w": (0.5, 2.0)}, best={"controller.soc_gain_w": 1.5},
        objective_start=1.0, objective_best=0.5, tests=["a"], holdout=["61410013_Test_Data"],
        before=errs, after=errs, n_evaluations=1, n_simulations=1, elapsed_s=0.0,
        method="grid", dt=1.0, vehicle=nominal,
        prior={"61410013 Test Data": ["body.aux_power_w"]})
    assert res.in_sample("61410013_Test_Data")
    assert res.rows()[1][1].startswith("held out (in-sample")
    assert res.sample_stats()["n_tests"] == 0
