"""Virtual tests from a Prius with perturbed controller parameters (known truth).

The "measurements" are simulations at dt = 1 s of the perturbed vehicle (signals renamed
``_simu`` -> ``_test``), so the model with the true parameters reproduces them exactly and
every error left after calibration comes from identifiability or the search.
"""

from __future__ import annotations

import pytest

from vehval.sim.simulate import simulate
from vehval.sim.vehicle import load_vehicle

from .helpers import sim_as_test

#: The perturbed ("true") parameters: the nominal file has 8000 W, 150 kW/SOC and 0.9.
TRUTH = {"controller.engine_on_power_w": 11000.0, "controller.soc_gain_w": 100000.0,
         "controller.regen_fraction_max": 0.75}
TUNE_CYCLES = ("japan1015", "hwfet")
HOLDOUT_CYCLES = ("udds", "nedc")


@pytest.fixture(scope="session")
def nominal():
    return load_vehicle("prius_2004")


@pytest.fixture(scope="session")
def virtual_tests(nominal):
    """cycle -> virtual test of the perturbed vehicle (dt = 1 s, initial SOC 0.6)."""
    out = {}
    for cyc in TUNE_CYCLES + HOLDOUT_CYCLES:
        r = simulate(nominal, cyc, dt=1.0, soc_initial=0.6, **TRUTH)
        out[cyc] = sim_as_test(r.test, f"virtual_{cyc}", cyc,
                               {"test_mass_kg": nominal.body.mass_kg, "road_load_a_n": 88.6,
                                "road_load_b_n_per_mps": 0.14, "road_load_c_n_per_mps2": 0.36})
    return out
