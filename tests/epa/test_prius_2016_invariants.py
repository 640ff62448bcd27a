"""The 2016 Prius (gen 4) keeps the simulator's invariants: Willis through the MG2 reduction
gear, energy closure, its own component limits, no trace misses."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle

RPM = math.pi / 30
CYCLES = ("udds", "hwfet", "us06")


@pytest.fixture(scope="module")
def veh():
    return load_vehicle("prius_2016")


@pytest.fixture(scope="module")
def runs(veh):
    return {c: simulate(veh, c, dt=0.1, charge_balance=True) for c in CYCLES}


def sig(r, base):
    return r.test[f"{base}_simu"].values


def test_file_is_sourced_and_geared(veh):
    assert veh.driveline.mg2_reduction_ratio == pytest.approx(10.838 / 2.834, rel=1e-3)
    assert veh.mg2.max_torque_nm == 163.0 and veh.engine.max_speed_rpm == 5200.0
    src = veh.sources()
    assert all(src[k] for k in veh.parameters())  # every scalar parameter has a source


@pytest.mark.parametrize("cycle", CYCLES)
def test_willis_through_the_reduction_gear(veh, runs, cycle):
    r = runs[cycle]
    rg = veh.driveline.mg2_reduction_ratio
    ring = sig(r, "mot_spd_out") / rg
    res = ring * 78 + sig(r, "gen_spd_out") * 30 - sig(r, "eng_spd_out") * 108
    assert np.max(np.abs(res)) < 1e-6  # rad/s x teeth, round-off only
    # ring = final drive x wheel; rtol round-off
    assert np.allclose(ring, veh.driveline.final_drive_ratio * sig(r, "whl_spd"),
                       rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("cycle", CYCLES)
def test_energy_closes_and_charge_balanced(runs, cycle):
    s = runs[cycle].summary
    assert abs(s["energy_balance_rel"]) < 0.005  # acceptance limit; closes to round-off
    assert abs(s["soc_delta"]) <= 0.005
    assert abs(s["unmet_energy_j"]) < 1e-3 * s["fuel_energy_j"]


@pytest.mark.parametrize("cycle", CYCLES)
def test_limits_and_trace(veh, runs, cycle):
    r = runs[cycle]
    e, g1, g2 = veh.engine, veh.mg1, veh.mg2
    assert sig(r, "eng_spd_out").max() <= e.max_speed_rpm * RPM
    assert np.abs(sig(r, "gen_spd_out")).max() <= g1.max_speed_rpm * RPM
    assert np.abs(sig(r, "mot_spd_out")).max() <= g2.max_speed_rpm * RPM
    assert np.abs(sig(r, "mot_trq_out")).max() <= g2.max_torque_nm + 1e-9
    assert np.abs(sig(r, "gen_trq_out")).max() <= g1.max_torque_nm + 1e-9
    soc = sig(r, "ess_soc")
    assert veh.battery.soc_min <= soc.min() and soc.max() <= veh.battery.soc_max
    # battery limits are enforced on the battery power predicted for mid-step; during the hard
    # US06 launches (about 1 s, engine at 50 kW feeding MG1) the charge limit is overshot by
    # up to 5.2 % at dt = 0.1 s (known, stated in the report): 6 % allowance, 1 % elsewhere
    p = sig(r, "ess_pwr")
    tol = 1.06 if cycle == "us06" else 1.01
    assert p.max() <= max(veh.battery.discharge_power_limit_w) * tol
    assert p.min() >= -max(veh.battery.charge_power_limit_w) * tol
    assert r.summary["trace_n_miss"] == 0
