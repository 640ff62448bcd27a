"""Generic technology coefficients: part-load pumping, efficiency against specific power."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from helpers.epa_lists import HEADER, camry_rows, write_list
from vehval.epa import engine_model as em
from vehval.epa import read_test_car_list
from vehval.epa import technology as tech
from vehval.epa.specs import specs_from_tests, vehicle_from_specs
from vehval.errors import ConfigError


@pytest.fixture
def specs(tmp_path):
    path = write_list(tmp_path / "19tstcar.csv", camry_rows(), header=HEADER)
    return specs_from_tests(read_test_car_list(path))


def test_pumping_falls_from_zero_load_to_nothing_at_full_load():
    full = np.array([10e5])
    assert em.pumping_mep_pa(np.array([0.0]), full, 0.5e5)[0] == pytest.approx(0.5e5)
    assert em.pumping_mep_pa(np.array([10e5]), full, 0.5e5)[0] == pytest.approx(0.0)
    spd, trq, tmax = np.array([1500.0, 3000.0]), np.array([0.0, 50.0, 200.0]), np.array([200.0, 200.0])
    base = em.fuel_rate_g_per_s(spd, trq, tmax, 2.0, 0.4, 1.0, 43e6)
    pumped = em.fuel_rate_g_per_s(spd, trq, tmax, 2.0, 0.4, 1.0, 43e6, pumping_pa=0.5e5)
    assert np.all(pumped[:, :2] > base[:, :2])  # light load: the throttle costs fuel
    assert np.allclose(pumped[:, 2], base[:, 2])  # wide open: no part-load pumping


def test_efficiency_against_specific_power():
    ref = tech.REFERENCE_SPECIFIC_POWER_W_PER_L
    assert tech.indicated_efficiency(0.4, 0.3, ref * 2.0, 2.0) == pytest.approx(0.4)
    assert tech.indicated_efficiency(0.4, 0.3, ref * 4.0, 2.0) == pytest.approx(0.4 * 2 ** -0.3)


def _with(coef, **engine):
    eng = {t: dict(v) for t, v in coef.engine.items()}
    for t in eng:
        for k, x in engine.items():
            eng[t][k] = tech.Coefficient(x, (x, x), "test")
    return dataclasses.replace(coef, engine=eng)


def test_vehicle_reads_the_coefficients(specs):
    base = tech.load_coefficients()
    c0 = _with(base, indicated_efficiency=0.4, friction_scale=1.0, idle_factor=1.0,
               pumping_bar=0.0, efficiency_specific_power_exponent=0.0)
    c1 = _with(base, indicated_efficiency=0.4, friction_scale=1.0, idle_factor=1.0,
               pumping_bar=0.0, efficiency_specific_power_exponent=0.3)
    v0 = vehicle_from_specs(specs, coefficients=c0)
    v1 = vehicle_from_specs(specs, coefficients=c1)
    spec = specs.rated_power_w / specs.displacement_l  # 61 kW/L: just above the reference
    ratio = (spec / tech.REFERENCE_SPECIFIC_POWER_W_PER_L) ** 0.3
    f0 = np.asarray(v0.engine.fuel_rate_g_per_s)
    f1 = np.asarray(v1.engine.fuel_rate_g_per_s)
    assert np.allclose(f1, f0 * ratio)  # fuel inverse in the efficiency
    assert "kW/L" in v1.sources()["engine.fuel_rate_g_per_s"]
    # a given efficiency (a calibration) is used as given
    v2 = vehicle_from_specs(specs, 0.4, coefficients=c1, technology=True)
    assert np.allclose(np.asarray(v2.engine.fuel_rate_g_per_s), f0)
    # the idle factor multiplies the map's idle
    c2 = _with(base, indicated_efficiency=0.4, friction_scale=1.0, idle_factor=2.0,
               pumping_bar=0.0, efficiency_specific_power_exponent=0.0)
    v3 = vehicle_from_specs(specs, coefficients=c2)
    assert v3.engine_control.idle_fuel_rate_g_per_s == pytest.approx(
        2.0 * v0.engine_control.idle_fuel_rate_g_per_s)
    # pumping raises the light-load fuel
    c3 = _with(base, indicated_efficiency=0.4, friction_scale=1.0, idle_factor=1.0,
               pumping_bar=0.5, efficiency_specific_power_exponent=0.0)
    f3 = np.asarray(vehicle_from_specs(specs, coefficients=c3).engine.fuel_rate_g_per_s)
    assert f3[8, 1] > f0[8, 1]


def test_technology_of_the_engine_by_specific_power():
    c = tech.load_coefficients()
    lim = c.turbo_min_specific_power_w_per_l
    assert tech.engine_technology(0.99 * lim * 2.0, 2.0, c) == "spark_na"
    assert tech.engine_technology(1.01 * lim * 2.0, 2.0, c) == "spark_turbo"
    for t in tech.ENGINE_TECHNOLOGIES:
        for k in tech.ENGINE_KEYS:
            v = c.engine_value(t, k)
            assert v is not None and v.interval[0] <= v.value <= v.interval[1] and v.source


def test_coefficients_file_out_of_bounds_refused(tmp_path):
    p = tmp_path / "c.yaml"
    p.write_text("engine:\n  spark_na:\n    indicated_efficiency: {value: 0.9, interval: "
                 "[0.8, 1.0], source: x}\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="indicated_efficiency' = 0.9 outside"):
        tech.load_coefficients(p)
    assert math.isfinite(tech.load_coefficients().turbo_min_specific_power_w_per_l)


def test_accessory_power_and_upshift_scale_reach_the_vehicle(specs):
    """The accessory load of the coefficients is the engine's (and burns more at idle); the
    family's upshift scale moves the upshift lines in proportion, with its source."""
    base = tech.load_coefficients()
    c0 = _with(base, accessory_power_w=300.0)
    c1 = _with(base, accessory_power_w=900.0)
    v0 = vehicle_from_specs(specs, coefficients=c0)
    v1 = vehicle_from_specs(specs, coefficients=c1)
    assert v0.engine_control.accessory_power_w == 300.0
    assert v1.engine_control.accessory_power_w == 900.0
    assert v1.engine_control.idle_fuel_rate_g_per_s > v0.engine_control.idle_fuel_rate_g_per_s
    assert "accessory power" in v1.sources()["engine_control.accessory_power_w"]
    fam = specs.family
    tr = {f: dict(v) for f, v in base.transmission.items()}
    tr[fam]["upshift_scale"] = tech.Coefficient(1.2, (1.2, 1.2), "test")
    c2 = dataclasses.replace(c0, transmission=tr)
    tr1 = {f: dict(v) for f, v in base.transmission.items()}
    tr1[fam]["upshift_scale"] = tech.Coefficient(1.0, (1.0, 1.0), "test")
    up1 = np.asarray(vehicle_from_specs(
        specs, coefficients=dataclasses.replace(c0, transmission=tr1)).gearbox.upshift_speed_mps)
    v2 = vehicle_from_specs(specs, coefficients=c2)
    assert np.allclose(np.asarray(v2.gearbox.upshift_speed_mps), 1.2 * up1)
    assert "upshift scale 1.2" in v2.sources()["gearbox.upshift_speed_mps"]
