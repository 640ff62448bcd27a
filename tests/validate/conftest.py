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

from .helpers import CONSTANTS, HOLDOUT_CYCLES, TRUTH, TUNE_CYCLES, _DynoDirs, sim_as_test


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



@pytest.fixture(scope="session")
def dyno_dirs(tmp_path_factory):
    """cycle -> directory of a virtual dyno test of the perturbed vehicle (faults 'none',
    seed 3), generated lazily."""
    synth = pytest.importorskip("vehval.synth")
    return _DynoDirs(tmp_path_factory.mktemp("dyno"), synth)
