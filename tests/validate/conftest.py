"""Virtual tests from a Prius with perturbed controller AND component parameters (known truth).

Two kinds of virtual measurement:

* ``virtual_tests``: simulations at dt = 1 s of the perturbed vehicle, signals renamed
  ``_simu`` -> ``_test`` and the target speed as the measured speed, so the model with the
  true parameters reproduces them exactly and every error left after calibration comes
  from identifiability or the search;
* ``dyno_tests``: the virtual dyno's files (``vehval.synth.make_virtual_test``, dt = 0.1 s,
  sensor noise, lags, quantised OBD SOC, no faults) imported and run through the QA
  pipeline, so the model replays the *measured* (sensor) speed trace.
"""

from __future__ import annotations

import pytest

from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle

from .helpers import sim_as_test

#: The perturbed ("true") parameters. The nominal file has 8000 W, 150 kW/SOC, 1.0 (controller),
#: 300 W accessory load and a final-drive efficiency of 0.97 (components).
TRUTH = {"controller.engine_on_power_w": 11000.0, "controller.soc_gain_w": 100000.0,
         "controller.regen_fraction_max": 0.75, "body.aux_power_w": 400.0,
         "driveline.final_drive_efficiency": 0.94}
CONTROLLER_TRUTH = {k.split(".", 1)[1]: v for k, v in TRUTH.items() if k.startswith("controller.")}
COMPONENT_TRUTH = {k: v for k, v in TRUTH.items() if not k.startswith("controller.")}
TUNE_CYCLES = ("japan1015", "hwfet")
HOLDOUT_CYCLES = ("udds", "nedc")
CONSTANTS = {"test_mass_kg": 1295.0, "road_load_a_n": 88.6, "road_load_b_n_per_mps": 0.14,
             "road_load_c_n_per_mps2": 0.36}


@pytest.fixture(scope="session")
def nominal():
    return load_vehicle("prius_2004")


@pytest.fixture(scope="session")
def virtual_tests(nominal):
    """cycle -> virtual test of the perturbed vehicle (dt = 1 s, initial SOC 0.6)."""
    out = {}
    for cyc in TUNE_CYCLES + HOLDOUT_CYCLES:
        r = simulate(nominal, cyc, dt=1.0, soc_initial=0.6, **TRUTH)
        out[cyc] = sim_as_test(r.test, f"virtual_{cyc}", cyc, CONSTANTS)
    return out


class _DynoDirs(dict):
    """cycle -> virtual dyno test directory, made on first use (once per test worker)."""

    def __init__(self, root, synth):
        super().__init__()
        self.root, self.synth = root, synth

    def __missing__(self, cycle: str):
        d = self.root / cycle
        self.synth.make_virtual_test("prius_2004", cycle, seed=3, faults="none", outdir=d,
                                     controller_overrides=CONTROLLER_TRUTH,
                                     vehicle_overrides=COMPONENT_TRUTH)
        self[cycle] = d
        return d


@pytest.fixture(scope="session")
def dyno_dirs(tmp_path_factory):
    """cycle -> directory of a virtual dyno test of the perturbed vehicle (faults 'none',
    seed 3), generated lazily."""
    synth = pytest.importorskip("vehval.synth")
    return _DynoDirs(tmp_path_factory.mktemp("dyno"), synth)
