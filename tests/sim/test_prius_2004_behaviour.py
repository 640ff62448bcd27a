"""Known behaviour of the 2004 Prius, held by the packaged model on the charge-balanced cycles:
electric launch then engine start, engine off at standstill and in most urban decelerations,
electric-only propulsion below about 68 km/h (the car's published EV limit)."""

import numpy as np
import pytest

from vehval.constants import KMH_M_PER_S
from vehval.sim.simulate import simulate

URBAN = ("udds", "japan1015", "nedc")
ALL = URBAN + ("hwfet", "us06")


@pytest.fixture(scope="module")
def runs():
    return {c: simulate("prius_2004", c, dt=0.1, charge_balance=True) for c in ALL}


def _sig(run, base):
    return np.asarray(run.test[f"{base}_simu"].values)


@pytest.mark.parametrize("cycle", ALL)
def test_engine_off_at_standstill_and_electric_launch(runs, cycle):
    v, on = _sig(runs[cycle], "veh_spd"), _sig(runs[cycle], "eng_on") > 0.5
    stand = v < 0.05
    assert on[stand].mean() <= 0.02
    launches = np.flatnonzero((v[1:] > 0.05) & (v[:-1] <= 0.05)) + 1
    assert launches.size >= 1 and not on[launches].any()  # every launch is electric
    # ... and the engine starts once the car is moving
    first_start = np.flatnonzero(on)[0]
    assert v[first_start] > 0.05 and first_start > launches[0]


@pytest.mark.parametrize("cycle", URBAN)
def test_engine_off_in_most_urban_decelerations(runs, cycle):
    a, on = _sig(runs[cycle], "veh_acc"), _sig(runs[cycle], "eng_on") > 0.5
    assert 1 - on[a < -0.3].mean() > 0.75


@pytest.mark.parametrize("cycle", ALL)
def test_electric_only_propulsion_below_68_kmh(runs, cycle):
    r = runs[cycle]
    v, on, p = _sig(r, "veh_spd"), _sig(r, "eng_on") > 0.5, _sig(r, "drv_pwr_demand")
    ev = (p > 0) & ~on
    assert v[ev].max() < 68 * KMH_M_PER_S
