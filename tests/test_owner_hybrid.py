"""One rule for "is this car a hybrid": :func:`vehval.test.is_hybrid` (from a vehicle
file's blocks) agrees with the stage registry's :attr:`vehval.architectures.Stages.is_hybrid`
(a traction battery and a fuel) for every architecture; a battery-electric car is no hybrid."""

from __future__ import annotations

import pytest

from helpers.bev import bev_data
from vehval.architectures import REGISTRY, stages
from vehval.identify.traces import hybrid_refusal
from vehval.test import Test, TestMeta, is_hybrid
from vehval.vehicle import list_vehicles, load_vehicle
from vehval.vehicle.definition import ARCHITECTURES


def _vehicles() -> list:
    vehs = [load_vehicle(n) for n in list_vehicles()]
    vehs.append(ARCHITECTURES["battery_electric"].model_validate(bev_data()))
    return vehs


def test_every_registered_architecture_has_a_vehicle_here():
    assert {v.architecture for v in _vehicles()} == set(REGISTRY)


@pytest.mark.parametrize("veh", _vehicles(), ids=lambda v: v.name)
def test_is_hybrid_asks_the_registry(veh):
    assert is_hybrid(Test(), veh) == stages(veh).is_hybrid


def test_a_battery_electric_car_is_no_hybrid():
    bev = ARCHITECTURES["battery_electric"].model_validate(bev_data())
    assert not stages(bev).is_hybrid and not is_hybrid(Test(), bev)
    assert stages("power_split").is_hybrid and not stages("conventional").is_hybrid


def test_identify_refuses_a_battery_electric_car_for_its_missing_engine():
    bev = ARCHITECTURES["battery_electric"].model_validate(bev_data())
    msg = hybrid_refusal(Test(meta=TestMeta(test_id="t1")), bev)
    assert msg and "without an engine" in msg and "hybrid" not in msg.split(":")[1]
    assert hybrid_refusal(Test(), load_vehicle("cruze_diesel_2014")) is None
