"""Does the vehicle model match the test? Checked before a validation is believed.

Validating a diesel conventional car against a gasoline power-split hybrid model gives a
number ("fuel 30.5 % FAIL") that says nothing about the model. :func:`vehicle_match` lists
what contradicts the pairing, from the test's own evidence:

* **architecture**: a hybrid model on a test with no battery, motor or generator signal
  (or a conventional model on a test with them);
* **fuel**: the test's declared fuel (template ``fuel:`` or constants) 7 % denser or lighter
  than the vehicle's (diesel about
  830-850 kg/m³, gasoline about 740-750 kg/m³);
* **mass**: the template's test mass more than 25 % from the vehicle's mass.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from vehval.conditions import TestConditions, vehicle_value
from vehval.fuels import resolve_fuel, vehicle_fuel
from vehval.test import Test, hybrid_signals

FUEL_DENSITY_TOL = 0.07
MASS_TOL = 0.25


@dataclass
class VehicleMatch:
    """The outcome: ``problems`` (one sentence each); the pairing matches when it is empty."""

    vehicle: str
    test_id: str
    problems: list[str] = field(default_factory=list)

    @property
    def matches(self) -> bool:
        return not self.problems

    def to_dict(self) -> dict:
        return {"matches": self.matches, "problems": list(self.problems)}

    def message(self) -> str:
        return (f"vehicle {self.vehicle} does not match test {self.test_id}: "
                + "; ".join(self.problems) + ": the validation compares different cars")


def has_hybrid_signals(test: Test) -> bool:
    """True when the test measured a battery, motor or generator quantity."""
    return bool(hybrid_signals(test))


def _fuel_kind(rho: float) -> str:
    return "diesel" if rho > 800 else "gasoline" if 700 <= rho <= 780 else "fuel"


def vehicle_match(test: Test, vehicle: Any) -> VehicleMatch:
    """What in ``test`` contradicts ``vehicle`` (see the module docstring)."""
    name = str(getattr(vehicle, "name", vehicle))
    out = VehicleMatch(name, test.meta.test_id or "test")
    hybrid_model = getattr(vehicle, "architecture", "power_split") != "conventional"
    hybrid_test = has_hybrid_signals(test)
    if hybrid_model and not hybrid_test:
        out.problems.append("the model is a hybrid but the test has no battery, motor or "
                            "generator signal (a conventional car?)")
    elif not hybrid_model and hybrid_test:
        out.problems.append("the model is a conventional car but the test has battery or "
                            "electric machine signals (a hybrid?)")
    test_fuel, veh_fuel = resolve_fuel(test=test), vehicle_fuel(vehicle)
    tv = test_fuel.density_kg_per_m3 if test_fuel is not None else None
    vv = veh_fuel.density_kg_per_m3 if veh_fuel is not None else None
    if tv and vv and abs(tv / vv - 1) > FUEL_DENSITY_TOL:
        out.problems.append(f"fuel density {tv:g} kg/m³ in the test ({_fuel_kind(tv)}), "
                            f"{vv:g} in the vehicle ({_fuel_kind(vv)})")
    cond = TestConditions.resolve(test, None, vehicle)
    if (cond.source("test_mass_kg") or "").startswith("template"):
        tv, vv = cond["test_mass_kg"], vehicle_value(vehicle, "body.mass_kg")
        if vv and abs(tv / vv - 1) > MASS_TOL:
            out.problems.append(f"test mass {tv:g} kg, vehicle {vv:g} kg ({100 * (tv / vv - 1):+.0f} %)")
    return out
