"""The named steps of the results stage: typed objects that compose into compute_results."""

import numpy as np
import pytest

from vehval.results import compute_results
from vehval.results.steps import (
    SCOPE_TEST,
    Accuracies,
    Inputs,
    PhasePlan,
    ResultsModel,
    ScopeIntegrals,
    accuracies,
    fuel_of_test,
    integrate_scopes,
    plan_phases,
    propagate_results,
    select_inputs,
)
from vehval.test import Signal

from .helpers import make_test, true_signals

EXPLICIT = {"density_kg_per_m3": 800.0, "lhv_j_per_kg": 42e6, "carbon_mass_fraction": 0.86}


def test_steps_return_typed_objects_that_give_the_stage_figures():
    t, s = true_signals()
    test = make_test(t, s)
    notes, findings = [], []
    fuel = fuel_of_test(test, EXPLICIT, notes)
    inputs = select_inputs(test, None, fuel, findings)
    assert isinstance(inputs, Inputs) and inputs.speed is not None and inputs.fuel is not None
    plan = plan_phases(test, inputs.speed, None, findings)
    assert isinstance(plan, PhasePlan) and plan.scopes == ["bag1", "bag2", SCOPE_TEST]
    assert plan.channel == "test_phase_test"
    ints = integrate_scopes(inputs, plan)
    assert isinstance(ints, ScopeIntegrals)
    # the phases tile the test: their distances add up to the whole test's
    dist = ints.speed[0]
    assert dist[0] + dist[1] == pytest.approx(dist[2], rel=1e-9)
    acc = accuracies(inputs, {}, fuel)
    assert isinstance(acc, Accuracies)
    model = ResultsModel(inputs, ints, fuel, plan.scopes, [], None)
    res = propagate_results(model, acc.parameters, method="first_order", draws=10, seed=0,
                            notes=notes)
    whole = compute_results(test, fuel=EXPLICIT)
    for qty in ("distance_m", "fuel_mass_kg", "fuel_economy_mpg", "co2_kg"):
        assert res.values["test"][qty] == whole.value("test", qty)
        assert res.values["bag1"][qty] == whole.value("bag1", qty)


def test_battery_energy_from_voltage_and_current_is_positive_discharged():
    t, s = true_signals()
    test = make_test(t, s)
    test.add(Signal.standard("ess_volt_test", t, np.full_like(t, 200.0), source="dyno"))
    # discharge, then charge
    test.add(Signal.standard("ess_curr_test", t, np.where(t < t[-1] / 2, 10.0, -5.0),
                             source="dyno"))
    res = compute_results(test, fuel=EXPLICIT)
    assert res.inputs["ess"] == ["ess_volt_test", "ess_curr_test"]
    half = (t[-1] - t[0]) / 2
    assert res.value("test", "ess_energy_net_j") == pytest.approx(
        200.0 * (10.0 * half - 5.0 * half), rel=2e-3)
