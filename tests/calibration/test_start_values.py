"""`calibrate --start`: every given start is a finite number inside the parameter's bounds
(the model's limits, within 10 x the vehicle's value), read with bounded size and depth;
each refusal is one line naming the file or the parameter, before any test is read."""

from __future__ import annotations

import json

import pytest

from vehval.cli import main
from vehval.errors import ConfigError
from vehval.validate.calibration import START_FACTOR, check_start, start_limits, start_values
from vehval.vehicle import load_vehicle


def _calibrate(tmp_path, start_text: str, params: str = "engine_on_power_w"):
    start = tmp_path / "start.json"
    start.write_text(start_text)
    (tmp_path / "t1").mkdir(exist_ok=True)      # never read: the start is refused first
    out = tmp_path / "cal"
    rc = main(["calibrate", str(tmp_path / "t1"), "--vehicle", "prius_2004", "--params", params,
               "--start", str(start), "-o", str(out)])
    return rc, out, start


@pytest.mark.parametrize("text, says", [
    ('{"engine_on_power_w": 1e300}', "'controller.engine_on_power_w' 1e+300 is outside its bounds"),
    ('{"engine_on_power_w": -1e300}', "is outside its bounds"),
    ('{"controller": {"regen_fraction_max": {"value": 1.5}}}',
     "'controller.regen_fraction_max' 1.5 is outside its bounds 0 to 1"),
    ('{"engine_on_power_w": NaN}', "'engine_on_power_w': nan is not a finite number"),
    ('{"engine_on_power_w": Infinity}', "'engine_on_power_w': inf is not a finite number"),
    ('{"engine_on_power_w": 1e400}', "'engine_on_power_w': inf is not a finite number"),
    ('{"engine_on_power_w": "12 kW"}', "'engine_on_power_w': '12 kW' is not a finite number"),
])
def test_a_start_outside_its_bounds_or_not_finite_is_refused(tmp_path, capsys, text, says):
    params = "regen_fraction_max" if "regen" in text else "engine_on_power_w"
    rc, out, _ = _calibrate(tmp_path, text, params)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert says in err[0], err
    assert not out.exists()


def test_a_start_nested_50000_deep_is_refused_in_one_line(tmp_path, capsys):
    rc, out, start = _calibrate(tmp_path, "[" * 50_000 + "]" * 50_000)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert str(start) in err[0] and "nesting deeper than 64 levels" in err[0], err
    assert not out.exists()


def test_the_bounds_are_the_model_limits_within_a_factor_of_the_vehicle_value():
    veh = load_vehicle("prius_2004")
    p = veh.controller.engine_on_power_w
    lo, hi = start_limits(veh, "controller.engine_on_power_w")
    assert (lo, hi) == (-START_FACTOR * abs(p), START_FACTOR * abs(p))
    assert start_limits(veh, "controller.regen_fraction_max") == (0.0, 1.0)
    check_start(veh, {"controller.engine_on_power_w": 3 * p}, ["controller.engine_on_power_w"])
    with pytest.raises(ConfigError, match="outside its bounds"):
        check_start(veh, {"controller.engine_on_power_w": 11 * p},
                    ["controller.engine_on_power_w"])
    # a value given for a parameter not tuned is not judged (it is reported as not tuned)
    check_start(veh, {"controller.engine_on_power_w": 1e300}, ["controller.soc_gain_w"])
    # null means "not given"
    assert start_values(json.loads('{"engine_on_power_w": null, "soc_gain_w": 2}')) == {
        "controller.soc_gain_w": 2.0}


def test_text_is_refused_for_a_tuned_parameter_only():
    """A note in control.json is not a start value; text given for a tuned parameter is."""
    doc = {"controller": {"engine_on_power_w": "12 kW", "note": "x", "soc_gain_w": 2.0}}
    assert start_values(doc) == {"controller.soc_gain_w": 2.0}
    with pytest.raises(ConfigError, match="'engine_on_power_w': '12 kW' is not a finite number"):
        start_values(doc, ["controller.engine_on_power_w"])
