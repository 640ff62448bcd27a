"""EPA calibration: recovers a known controller value from virtual EPA results; provenance,
written vehicle, CLI and bad input."""

from __future__ import annotations

import dataclasses
import json

import pytest

from vehval.cli import main
from vehval.epa import read_test_car_list
from vehval.epa.calibrate import calibrate_on_tests, judged_errors
from vehval.epa.validation import validate_tests
from vehval.errors import ConfigError
from vehval.vehicle import load_vehicle

PARAM = "controller.engine_min_power_w"
TRUTH = 10500.0


@pytest.fixture(scope="module")
def virtual(tmp_path_factory):
    """The EPA HWFET and US06 rows with their results replaced by the model's own predictions
    at PARAM = TRUTH (virtual lab results: the calibration must find TRUTH again)."""
    from helpers.epa_lists import row, write_list

    path = write_list(tmp_path_factory.mktemp("epa") / "16tstcar.csv", [
        row(number="T1", code=3, desc="HWFE", fe=71.2),
        row(number="T2", code=90, desc="US06", fe=48.6, bags=(35.4, 54.4, "", ""))])
    tests = read_test_car_list(path)
    base = load_vehicle("prius_2016")
    truth = validate_tests(base.with_overrides({PARAM: TRUTH}), tests)
    out = []
    for t, p in zip(tests, truth.predictions):
        bags = tuple(p.bags_mpg.get(k + 1, float("nan")) if t.bags[k] == t.bags[k] else t.bags[k]
                     for k in range(4))
        out.append(dataclasses.replace(t, fe=p.overall_mpg, bags=bags))
    return base, out


@pytest.mark.slow
def test_recovers_the_value_that_made_the_results(virtual):
    base, tests = virtual
    grid = [9000.0, TRUTH, 12000.0]
    cal = calibrate_on_tests(base.with_overrides({PARAM: 12000.0}), tests, {PARAM: grid},
                             refine_rounds=0)
    assert cal.best == {PARAM: TRUTH}
    assert cal.best_rms < 1e-9 < cal.start_rms
    others = [e["rms_error"] for e in cal.evaluations if e["values"][PARAM] != TRUTH]
    assert len(others) == 2 and min(others) > 0.002  # the figures do depend on the value
    assert cal.tests == ["T1", "T2"]
    errs = judged_errors(validate_tests(cal.calibrated_vehicle(), tests))
    assert errs.size == 4 and abs(errs).max() < 1e-9  # HWFET, US06 whole and both parts


@pytest.mark.slow
def test_parallel_workers_give_the_same_result(virtual):
    base, tests = virtual
    grid = {PARAM: [9000.0, 12000.0]}
    one = calibrate_on_tests(base, tests[:1], grid, refine_rounds=1)
    two = calibrate_on_tests(base, tests[:1], grid, refine_rounds=1, workers=2)
    assert one.best == two.best and one.best_rms == two.best_rms
    assert one.evaluations == two.evaluations and len(one.evaluations) == 4


@pytest.mark.slow
def test_written_vehicle_carries_the_value_and_its_provenance(virtual, tmp_path):
    base, tests = virtual
    cal = calibrate_on_tests(base, tests, {"engine_min_power_w": [TRUTH]}, refine_rounds=0)
    path = cal.write_vehicle(tmp_path / "cal.yaml")
    veh = load_vehicle(path)
    assert veh.controller.engine_min_power_w == TRUTH
    src = veh.controller.sources["engine_min_power_w"]
    assert "T1, T2" in src and "vehval epa calibrate" in src and "RMS" in src
    assert veh.engine == base.engine and veh.body == base.body


@pytest.mark.slow
def test_bad_parameters_refused(virtual):
    base, tests = virtual
    with pytest.raises(ConfigError, match="did you mean controller.soc_gain_w"):
        calibrate_on_tests(base, tests, {"controller.soc_gan_w": [1.0]})
    with pytest.raises(ConfigError, match="finite"):
        calibrate_on_tests(base, tests, {"soc_gain_w": [float("nan")]})
    with pytest.raises(ConfigError, match="at least one"):
        calibrate_on_tests(base, tests, {})
    # a value outside the parameter's own constraint is named before anything runs
    with pytest.raises(ConfigError, match="soc_gain_w' = -5 is not a valid value: .*equal to 0"):
        calibrate_on_tests(base, tests, {"soc_gain_w": [1000.0, -5.0]})
    # each value valid alone, no valid combination: refused, not a "best" with infinite error
    on = base.controller.engine_on_power_w
    with pytest.raises(ConfigError, match="no setting of the grid gives finite figures"):
        calibrate_on_tests(base, tests[:1], {"engine_on_power_w": [on - 1000.0],
                                             "engine_off_power_w": [on - 500.0]},
                           refine_rounds=0)


def test_cli(prius_list, tmp_path, capsys):
    out = tmp_path / "v.yaml"
    rc = main(["epa", "calibrate", str(prius_list), "--vehicle", "prius_2016", "--tests",
               "model=PRIUS,originator=EPA,procedure=hwfet", "--param",
               "engine_min_power_w=9000,11000", "--refine", "0", "--workers", "1", "--json",
               "-o", str(out)])
    assert rc == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) >= {"vehicle", "tests", "grid", "best", "start", "start_rms_error",
                         "best_rms_error", "best_max_abs_error", "n_evaluations"}
    assert data["n_evaluations"] == 2 and data["tests"] == ["T1"]
    assert load_vehicle(out).controller.engine_min_power_w == data["best"][PARAM]
    # only SC03 / cold CO: nothing judged to calibrate on
    assert main(["epa", "calibrate", str(prius_list), "--vehicle", "prius_2016", "--tests",
                 "model=PRIUS,originator=MFR,procedure=sc03", "--param",
                 "soc_gain_w=1e4"]) == 2
    assert "no judged" in capsys.readouterr().err
    assert main(["epa", "calibrate", str(prius_list), "--vehicle", "prius_2016", "--tests",
                 "model=PRIUS", "--param", "soc_gain_w"]) == 2
    assert "NAME=v1,v2" in capsys.readouterr().err


def test_unknown_parameter_of_a_conventional_car_names_its_blocks(tmp_path):
    """A bare name means controller.NAME; on a car without a controller (`epa vehicle`'s
    conventional cars) the message suggested 'controller.soc_gain_w', a parameter it has
    not either. It now names the same parameter in another block, or the blocks."""
    from helpers.epa_lists import HEADER, camry_rows, write_list
    from vehval.epa.specs import specs_from_tests, vehicle_from_specs

    rows = read_test_car_list(write_list(tmp_path / "l.csv", camry_rows(), header=HEADER))
    car = vehicle_from_specs(specs_from_tests(rows))
    with pytest.raises(ConfigError, match=r"did you mean engine_control\.accessory_power_w\?"):
        calibrate_on_tests(car, rows, {"accessory_power_w": [200.0, 300.0]})
    with pytest.raises(ConfigError) as err:
        calibrate_on_tests(car, rows, {"soc_gain_w": [1.0, 2.0]})
    msg = str(err.value)
    assert "a bare name is controller.soc_gain_w" in msg and "did you mean" not in msg
    assert "blocks body, converter, driveline, driver, engine, engine_control, gearbox" in msg


def test_two_grids_of_one_parameter_refused(prius_list, capsys):
    """The first of two grids of one parameter was silently dropped."""
    for second in ("engine_min_power_w=1,2", "controller.engine_min_power_w=1,2"):
        rc = main(["epa", "calibrate", str(prius_list), "--vehicle", "prius_2016", "--tests",
                   "model=PRIUS,procedure=hwfet", "--param", "engine_min_power_w=9000,11000",
                   "--param", second, "--refine", "0", "--workers", "1"])
        assert rc == 2
        err = capsys.readouterr().err
        assert "parameter 'controller.engine_min_power_w' is given two grids" in err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    base = load_vehicle("prius_2016")
    with pytest.raises(ConfigError, match="given two grids"):
        calibrate_on_tests(base, [], {"soc_gain_w": [1.0], "controller.soc_gain_w": [2.0]})


def test_grid_size_bounded_before_anything_runs(prius_list, capsys, monkeypatch):
    """A 5,000-value grid or a 60^3 grid ran with no bound, no estimate and no output."""
    import vehval.epa.calibrate as cal_mod
    from vehval.epa.calibrate import MAX_GRID_POINTS

    def no_run(*a, **k):
        raise AssertionError("simulated before the grid was refused")

    monkeypatch.setattr(cal_mod, "validate_tests", no_run)
    big = ",".join(str(9000 + k) for k in range(5000))
    cube = ",".join(str(1000 + k) for k in range(60))
    for params in (["engine_min_power_w=" + big],
                   ["engine_min_power_w=" + cube, "soc_gain_w=" + cube,
                    "engine_on_power_w=" + cube]):
        args = ["epa", "calibrate", str(prius_list), "--vehicle", "prius_2016", "--tests",
                "model=PRIUS,procedure=hwfet"]
        for p in params:
            args += ["--param", p]
        assert main(args) == 2
        err = capsys.readouterr().err
        assert f"more than the {MAX_GRID_POINTS:,} of one calibration" in err
        assert ("5,000 settings" in err) or ("216,000 settings (60 x 60 x 60 values)" in err)


@pytest.mark.slow
def test_long_run_estimated_stated_and_refused_unless_asked(virtual, monkeypatch):
    import vehval.epa.calibrate as cal_mod

    base, tests = virtual
    said: list[str] = []
    with pytest.raises(ConfigError, match=r"would take about .* settings x 2 tests.*--long-run"):
        calibrate_on_tests(base, tests, {PARAM: [9000.0, 10000.0, 11000.0]}, refine_rounds=0,
                           max_seconds=1e-6, notify=said.append)
    assert said == []
    monkeypatch.setattr(cal_mod, "STATE_ESTIMATE_S", 0.0)
    cal = calibrate_on_tests(base, tests, {PARAM: [9000.0, 11000.0]}, refine_rounds=1,
                             notify=said.append)
    # stated before the run: the settings bound (2 grid + 2 refinement), tests, time per setting
    assert len(said) == 1 and said[0].startswith("epa calibrate: at most 4 settings x 2 tests")
    assert "s per setting measured on the start values, 1 worker(s): about" in said[0]
    assert len(cal.evaluations) <= 4
