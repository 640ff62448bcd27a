"""The fuel package: the table, the one resolver (its order and provenance), the quantities."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehval.errors import ConfigError
from vehval.fuels import (
    combine_mpg,
    economy,
    fuel_consumption_l_per_100km,
    fuel_economy_mpg,
    fuel_volume_m3,
    mpg_from_volume_per_distance,
    require,
    resolve_fuel,
    table_fuel,
)
from vehval.test import Test, TestMeta
from vehval.vehicle import load_vehicle


def _test(fuel=None, **constants) -> Test:
    return Test(meta=TestMeta(test_id="t", fuel=fuel, constants=constants))


def test_mpg_and_l_per_100km_against_the_definitions():
    # 100 miles on 2 US gallons of fuel: 50 mpg, and 235.215 / 50 L/100 km (exact factors)
    gal = 3.785411784e-3
    vol = 2 * gal
    assert fuel_economy_mpg(100 * 1609.344, vol) == pytest.approx(50.0, rel=1e-12)
    assert fuel_consumption_l_per_100km(vol, 100 * 1609.344) == pytest.approx(
        2 * 3.785411784 / 1.609344, rel=1e-12)
    assert mpg_from_volume_per_distance(vol / (100 * 1609.344)) == pytest.approx(50.0, rel=1e-12)
    # no fuel: nan by default, inf for a simulator that asks for it; no distance: nan
    assert math.isnan(fuel_economy_mpg(1000.0, 0.0))
    assert fuel_economy_mpg(1000.0, 0.0, empty=math.inf) == math.inf
    assert math.isnan(fuel_consumption_l_per_100km(1e-3, 0.0))
    arr = fuel_economy_mpg(np.array([1.0, 2.0]) * 1609.344, np.array([gal, gal]))
    np.testing.assert_allclose(arr, [1.0, 2.0], rtol=1e-12)
    # two runs: total distance over total volume
    assert combine_mpg([10.0, 30.0], [20.0, 60.0]) == pytest.approx(40.0 / (0.5 + 0.5))


def test_economy_of_a_table_fuel():
    d = table_fuel("diesel")
    e = economy(1.0, 20_000.0, d)
    assert e["fuel_volume_m3"] == pytest.approx(1.0 / 851.0)
    assert e["fuel_energy_j"] == pytest.approx(42.8e6)
    assert e["co2_kg"] == pytest.approx(0.869 * 44.009 / 12.011)
    assert e["fuel_economy_mpg"] == fuel_economy_mpg(20_000.0, fuel_volume_m3(1.0, 851.0))
    none = economy(1.0, 20_000.0, None)
    assert all(v is None for v in none.values())


def test_resolver_order_and_provenance():
    veh = load_vehicle("prius_2004")
    # 1. the template's fuel: key (kept in the test metadata at import) beats everything
    r = resolve_fuel(test=_test("diesel", fuel_density_kg_per_m3=800.0), vehicle=veh)
    assert (r.name, r.origin, r.density_kg_per_m3) == ("diesel", "template fuel", 851.0)
    # 2. explicit constants beat the vehicle, per value; no carbon fraction (no CO2)
    r = resolve_fuel(test=_test(None, fuel_density_kg_per_m3=800.0), vehicle=veh)
    assert (r.name, r.origin, r.density_kg_per_m3, r.carbon_mass_fraction) == (
        "explicit", "template constants", 800.0, None)
    assert r.sources["density_kg_per_m3"] == "template constant fuel_density_kg_per_m3"
    assert r.lhv_j_per_kg == table_fuel("gasoline_e0").lhv_j_per_kg
    assert r.sources["lhv_j_per_kg"] == "vehicle prius_2004 engine.fuel_lhv_j_per_kg"
    assert resolve_fuel(test=_test(None, fuel_density_kg_per_m3=800.0)).lhv_j_per_kg is None
    # explicit constants given by the caller beat the test's
    r = resolve_fuel(test=_test(None, fuel_density_kg_per_m3=800.0),
                     constants={"fuel_density_kg_per_m3": 810.0})
    assert r.density_kg_per_m3 == 810.0
    # 3. the vehicle's named fuel, from the table
    r = resolve_fuel(test=_test(), vehicle=veh)
    assert (r.name, r.origin) == ("gasoline_e0", "vehicle prius_2004")
    assert r.density_kg_per_m3 == table_fuel("gasoline_e0").density_kg_per_m3
    # nothing: no fuel (there is no default)
    assert resolve_fuel(test=_test()) is None
    with pytest.raises(ConfigError, match="needs the fuel lhv_j_per_kg: no fuel is declared"):
        require(None, "lhv_j_per_kg", "identify")


def test_vehicle_names_a_fuel_of_the_table():
    for name in ("prius_2004", "prius_2016", "cruze_diesel_2014"):
        eng = load_vehicle(name).engine
        fuel = table_fuel(eng.fuel)
        assert (eng.fuel_density_kg_per_m3, eng.fuel_lhv_j_per_kg) == (
            fuel.density_kg_per_m3, fuel.lhv_j_per_kg)
        assert eng.sources["fuel_density_kg_per_m3"].startswith(f"fuel table {fuel.name}: ")


def test_vehicle_with_an_unknown_fuel_is_refused(tmp_path):
    import yaml

    from vehval.vehicle.definition import _vehicles_dir

    data = yaml.safe_load((_vehicles_dir() / "prius_2004.yaml").read_text(encoding="utf-8"))
    data["engine"]["fuel"] = "kerosene"
    p = tmp_path / "v.yaml"
    p.write_text(yaml.safe_dump(data), encoding="utf-8")
    with pytest.raises(ConfigError, match="unknown fuel 'kerosene'.*diesel"):
        load_vehicle(p)


def test_explicit_vehicle_values_beat_the_table(tmp_path):
    import yaml

    from vehval.vehicle.definition import _vehicles_dir

    data = yaml.safe_load((_vehicles_dir() / "prius_2004.yaml").read_text(encoding="utf-8"))
    data["engine"]["fuel_density_kg_per_m3"] = 750.0
    data["engine"]["sources"]["fuel_density_kg_per_m3"] = "measured density of the test batch"
    p = tmp_path / "v.yaml"
    p.write_text(yaml.safe_dump(data), encoding="utf-8")
    veh = load_vehicle(p)
    r = resolve_fuel(vehicle=veh)
    assert r.name == "gasoline_e0" and r.density_kg_per_m3 == 750.0
    assert r.lhv_j_per_kg == table_fuel("gasoline_e0").lhv_j_per_kg
    assert "measured density of the test batch" in r.sources["density_kg_per_m3"]
