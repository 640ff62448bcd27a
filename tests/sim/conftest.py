"""Shared fixtures for the simulator tests: simulations are run once per session."""

from __future__ import annotations

import pytest

from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle


@pytest.fixture(scope="session")
def prius():
    return load_vehicle("prius_2004")


@pytest.fixture(scope="session")
def runs(prius):
    """UDDS at dt = 0.1 s (the reference step) and the other cycles at dt = 0.5 s."""
    out = {"udds": simulate(prius, "udds", dt=0.1)}
    for name in ("hwfet", "us06", "japan1015"):
        out[name] = simulate(prius, name, dt=0.5)
    return out
