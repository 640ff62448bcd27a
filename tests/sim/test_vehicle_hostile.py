"""Mistaken vehicle files and overrides: one clear ConfigError naming the key and the value."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from vehval.errors import ConfigError
from vehval.safe_yaml import load_yaml
from vehval.vehicle import load_vehicle

RPM_PER_RAD_S = 30 / 3.141592653589793


def _shipped(name: str) -> dict:
    return yaml.safe_load(Path(load_vehicle(name).file).read_text(encoding="utf-8"))


def _load(tmp_path, data) -> str:
    """The ConfigError message of loading ``data`` written to a file (one line, names it)."""
    path = tmp_path / "vehicle.yaml"
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(ConfigError) as exc:
        load_vehicle(path)
    msg = str(exc.value)
    assert str(path) in msg and "\n" not in msg
    return msg


def _set(data, dotted, value):
    *path, key = dotted.split(".")
    for k in path:
        data = data[k]
    data[key] = value


@pytest.mark.parametrize("name, changes, expected", [
    ("prius_2004", {"controller.soc_target": 0.95}, "'controller.soc_target' = 0.95 is outside"),
    ("insight_2000", {"controller.soc_target": 0.05}, "'controller.soc_target' = 0.05 is outside"),
    ("prius_2004", {"battery.ocv_v": [0.0] * 11}, "'ocv_v' (open-circuit voltage) must be positive"),
    ("bev/nissan_leaf_2016", {"battery.soc": [x * 100 for x in range(12)]},
     "'soc' breakpoints must lie in [0, 1]"),
    ("prius_2004", {"engine.max_torque_nm": [-1.0] * 13}, "'max_torque_nm' (full-load torque)"),
    ("prius_2004", {"engine.fire_speed_rpm": 9000}, "'fire_speed_rpm' = 9000 must be below"),
    ("prius_2004", {"planetary.ring_teeth": 10}, "'ring_teeth' = 10 must exceed 'sun_teeth'"),
])
def test_physically_impossible_values_refused(tmp_path, name, changes, expected):
    data = _shipped(name)
    for key, value in changes.items():
        _set(data, key, value)
    assert expected in _load(tmp_path, data)


@pytest.mark.parametrize("name, block", [("prius_2004", "mg2"), ("cruze_diesel_2014", "engine"),
                                         ("insight_2000", "motor"),
                                         ("bev/nissan_leaf_2016", "motor")])
def test_map_speeds_in_rad_per_s_refused(tmp_path, name, block):
    data = _shipped(name)
    data[block]["speed_rpm"] = [x / RPM_PER_RAD_S for x in data[block]["speed_rpm"]]
    msg = _load(tmp_path, data)
    assert f"key '{block}'" in msg and "far below 'max_speed_rpm'" in msg


def test_message_gives_the_value_and_ragged_rows(tmp_path):
    data = _shipped("prius_2004")
    data["body"]["mass_kg"] = -1
    assert "key 'body.mass_kg': Input should be greater than or equal to 50 (got -1)" \
        in _load(tmp_path, data)
    data = _shipped("prius_2004")
    data["engine"]["fuel_rate_g_per_s"][1].pop()
    assert "'fuel_rate_g_per_s' rows have different lengths (12, 13)" in _load(tmp_path, data)


@pytest.mark.parametrize("name, arch", [("cruze_diesel_2014", "conventional"),
                                        ("bev/nissan_leaf_2016", "battery_electric")])
def test_missing_architecture_names_the_one_that_fits(tmp_path, name, arch):
    data = _shipped(name)
    del data["architecture"]
    msg = _load(tmp_path, data)
    assert "key 'architecture' is missing" in msg and f"add 'architecture: {arch}'" in msg


def test_variant_uncertainty_not_a_mapping(tmp_path):
    data = {"name": "v", "variant_of": "prius_2004",
            "body": {"mass_kg": 1400, "sources": {"mass_kg": "x"}, "uncertainty": [1]}}
    assert "key 'body.uncertainty': must be a mapping" in _load(tmp_path, data)


@pytest.mark.parametrize("name, override, expected", [
    ("bev/nissan_leaf_2016", {"driveline.mg2_reduction_ratio": 3.0}, "mg2_reduction_ratio"),
    ("bev/nissan_leaf_2016", {"charger.soc_initial": 0.01}, "'charger.soc_initial' = 0.01"),
    ("insight_2000", {"controller.assist_min_gear": 9}, "exceeds the 5 gears"),
    ("prius_2004", {"controller.soc_target": 0.95}, "'controller.soc_target' = 0.95"),
    ("prius_2004", {"battery.n_cells": 7}, "key 'battery': 'n_cells' must be a multiple"),
])
def test_overrides_get_the_vehicle_checks(name, override, expected):
    with pytest.raises(ConfigError, match="invalid override") as exc:
        load_vehicle(name).with_overrides(override)
    assert expected in str(exc.value)


def test_yaml_errors_are_one_line_with_the_line():
    with pytest.raises(ConfigError) as exc:
        load_yaml("name: x\nbody:\n  a: \x01\n", "f.yaml")
    assert str(exc.value).startswith("f.yaml line 3: ") and "\n" not in str(exc.value)
    with pytest.raises(ConfigError) as exc:
        load_yaml("mass_kg: " + "9" * 5000 + ".0\n", "f.yaml")
    assert len(str(exc.value)) < 200


def test_overrides_after_the_best_line_is_cached(prius):
    """The cached best-efficiency line is no field: a vehicle that computed it still takes
    overrides (sensitivity and batch runs override the shared base vehicle)."""
    veh = load_vehicle(prius.file)
    veh.best_line  # noqa: B018
    new = veh.with_overrides({"boost.efficiency": 0.95})
    assert new.boost.efficiency == 0.95 and new.file == veh.file


def test_a_battery_too_small_for_the_cycle_is_said_not_stated_as_physical(capsys):
    """A legal but tiny pack (0.5 Ah) ran the Leaf's SOC to -81 % and printed its MPGe as
    if physical: the run says so (summary ``warnings``, stderr); a sound run says nothing."""
    from vehval.cli import main
    from vehval.sim.simulate import simulate

    bad = simulate("bev/nissan_leaf_2016", "ece15", dt=0.5, **{"battery.capacity_ah": 0.2})
    assert any("state of charge left 0-100 %" in w for w in bad.summary["warnings"])
    assert simulate("bev/nissan_leaf_2016", "ece15", dt=0.5).summary["warnings"] == []
    assert main(["simulate", "--vehicle", "bev/nissan_leaf_2016", "--cycle", "ece15",
                 "--dt", "0.5", "--set", "battery.capacity_ah=0.2"]) == 0
    assert "vehval: warning: the battery's state of charge left 0-100 %" in capsys.readouterr().err
