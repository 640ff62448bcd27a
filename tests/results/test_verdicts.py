"""Model-vs-test verdicts against the measurement uncertainty."""

import numpy as np
import pytest

from vehval.test import Signal, Test
from vehval.test import TestMeta as Meta
from vehval.validate.compare import compare, uncertainty_verdict

from .helpers import true_signals


@pytest.mark.parametrize("sim, verdict", [(101.5, "within measurement uncertainty"),
                                          (102.5, "undecidable"), (104.0, "model error"),
                                          (98.1, "within measurement uncertainty")])
def test_verdict_zones(sim, verdict):
    r = uncertainty_verdict(100.0, sim, 1.0)          # u = 1: U = 2, error beyond 3
    assert r["verdict"] == verdict
    assert r["difference"] == pytest.approx(sim - 100.0) and r["U"] == 2.0
    assert r["ratio"] == pytest.approx(abs(sim - 100.0))
    assert "U = 2" in r["message"]


def test_unknown_uncertainty_is_undecidable():
    assert uncertainty_verdict(100.0, 150.0, None)["verdict"] == "undecidable"
    assert uncertainty_verdict(None, 150.0, 1.0)["verdict"] == "undecidable"


def _pair(scale):
    t, s = true_signals()
    test = Test(meta=Meta(test_id="v", cycle="udds"))
    test.add(Signal.standard("veh_spd_test", t, s["veh_spd"]))
    test.add(Signal.standard("fuel_rate_test", t, s["fuel_rate"]))
    sim = Test()
    sim.add(Signal.standard("veh_spd_simu", t, s["veh_spd"]))
    sim.add(Signal.standard("fuel_rate_simu", t, s["fuel_rate"] * scale))
    return test, sim


def test_compare_reports_verdicts_with_the_numbers():
    test, sim = _pair(1.05)                           # model burns 5 % more fuel
    comp = compare(test, sim, fuel_density_kg_per_m3=800.0, fuel_lhv_j_per_kg=42e6,
                   uncertainty_rel={"fuel_mass_kg": 0.01 / np.sqrt(3)}, uncertainty_basis="1 %")
    v = comp.verdicts()["fuel_mass_kg"]
    assert v["verdict"] == "model error" and v["ratio"] == pytest.approx(5 * np.sqrt(3), rel=1e-3)
    table = [t for t in comp.tables() if t["title"].startswith("Model against measurement")][0]
    assert table["rows"][0][-1] == "model error"
    assert comp.to_dict()["verdicts"]["fuel_mass_kg"]["verdict"] == "model error"
    test, sim = _pair(1.005)
    comp = compare(test, sim, uncertainty_rel={"fuel_mass_kg": 0.01 / np.sqrt(3)})
    assert comp.verdicts()["fuel_mass_kg"]["verdict"] == "within measurement uncertainty"
    assert compare(test, sim).verdicts() == {}        # no uncertainty: no verdict claimed
