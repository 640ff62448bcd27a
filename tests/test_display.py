"""The display-unit table: SI -> what a person reads, in both unit systems."""

from __future__ import annotations

import os

import numpy as np
import pytest

from vehval import display


@pytest.mark.parametrize("si, value, system, expected", [
    ("m/s", 0.44704, "us", "1 mph"),
    ("m/s", 25.0, "metric", "90 km/h"),
    ("rad/s", np.pi * 100 / 3.0, "us", "1000 rpm"),        # 1000 rpm
    ("kg/s", -1e-6, "us", "-0.001 g/s"),                   # the "-1e-06 kg/s" of the issue
    ("Pa", -5.6e4, "metric", "-56 kPa"),
    ("J", 3.02e7, "us", "30.2 MJ"),
    ("J", 5.0e3, "us", "5 kJ"),
    ("W", 12_500.0, "metric", "12.5 kW"),
    ("K", 298.15, "us", "25 degC"),
    ("N", 4.4482216152605, "us", "1 lbf"),
    ("kg", 0.45359237, "us", "1 lb"),
    ("m", 1609.344, "us", "1 mi"),
    ("m", 1500.0, "metric", "1.5 km"),
    ("m/s**2", 1.0, "metric", "1 m/s²"),
])
def test_hand_computed_conversions(si, value, system, expected):
    assert display.format_value(value, si, system_name=system) == expected


def test_fractions_show_in_percent_by_the_nomenclature_range():
    assert display.unit_for("dimensionless", signal="ess_soc_test").label == "%"
    assert display.format_value(0.0784, "dimensionless", signal="amb_rh_test") == "7.84 %"
    # a dimensionless count is not a fraction
    assert display.unit_for("dimensionless", signal="gb_gear_test").label == ""
    assert display.unit_for("dimensionless", signal="not_a_signal_test").label == ""


def test_round_trip_every_table_entry_both_systems():
    for si, row in display.TABLE.items():
        for system in display.SYSTEMS:
            unit = row[system]
            x = np.array([-3.0, 0.0, 7.5, 1234.0])
            back = (unit.convert(x) - unit.offset) / unit.factor
            np.testing.assert_allclose(back, x, rtol=1e-12, atol=1e-12, err_msg=f"{si} {system}")


def test_array_display_picks_one_unit_for_the_axis():
    values, label = display.to_display(np.array([1e5, 2e6, np.nan]), "J")
    assert label == "MJ"
    np.testing.assert_allclose(values[:2], [0.1, 2.0])


def test_system_choice_environment_and_errors(monkeypatch):
    monkeypatch.delenv(display.ENV_VAR, raising=False)
    assert display.system() == display.DEFAULT_SYSTEM
    monkeypatch.setenv(display.ENV_VAR, "metric")
    assert display.unit_for("m/s").label == "km/h"
    assert [n for n, _ in display.fuel_figures(50.0, 4.7)] == ["L/100 km", "mpg"]
    with pytest.raises(ValueError, match="us, metric"):
        display.system("imperial")


def test_keyed_result_values():
    assert display.format_keyed("distance_m", 11_990.0, system_name="us") == "7.45 mi"
    assert display.format_keyed("fuel_energy_j", 3.02e7) == "30.2 MJ"
    assert display.format_keyed("fuel_economy_mpg", 54.8) == "54.8"
    assert display.number(float("nan")) == "n/a"
    assert display.number(-1e-6) == "-1e-06" and display.number(12345.6) == "12\u2009346"


def test_keyed_compound_units_are_not_read_as_their_denominator():
    # the LHV was shown as '9.436e+07 lb' and road-load B as '27.59 mph' (the key's last token)
    assert display.format_keyed("fuel_lhv_j_per_kg", 42.8e6) == "42.8 MJ/kg"
    assert display.format_keyed("road_load_b_n_per_mps", 12.334, system_name="us") == "1.24 lbf/mph"
    assert display.format_keyed("road_load_b_n_per_mps", 12.334,
                                system_name="metric") == "12.33 N/(m/s)"
    assert display.format_keyed("road_load_c_n_per_mps2", 0.4,
                                system_name="us") == "0.01797 lbf/mph²"
    assert display.format_keyed("fuel_density_kg_per_m3", 851.0) == "851 kg/m³"
    assert display.format_keyed("idle_fuel_g_per_kg", 2.5) == "2.5"       # unknown: number only
    assert display.format_keyed("fuel_rate_kg_per_s", 1e-3) == "1 g/s"    # compound SI suffix


def test_keyed_small_length_is_a_dimension_not_a_distance():
    # a template's wheel_radius_m 0.305 was shown as '0.0001895 mi'
    assert display.format_keyed("wheel_radius_m", 0.305, system_name="us") == "0.305 m"
    assert display.format_keyed("distance_m", 11_990.0, system_name="us") == "7.45 mi"


def test_units_option_holds_for_one_run_only(monkeypatch, capsys):
    """``--units metric`` run in-process leaves the caller's unit system as it was."""
    from vehval.cli import main
    from vehval.display import ENV_VAR, system

    monkeypatch.delenv(ENV_VAR, raising=False)
    assert main(["--units", "metric", "cycles", "list"]) == 0
    assert ENV_VAR not in os.environ and system() == "us"
    monkeypatch.setenv(ENV_VAR, "us")
    assert main(["--units", "metric", "cycles", "list"]) == 0
    assert os.environ[ENV_VAR] == "us"
    capsys.readouterr()
