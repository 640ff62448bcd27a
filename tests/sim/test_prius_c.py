"""The Prius c built from its sheet: sourced, its own powertrain, the simulator's invariants."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.sim.simulate import simulate
from vehval.vehicle import load_vehicle


@pytest.fixture(scope="module")
def veh():
    return load_vehicle("prius_c")


def test_sheet_values_and_sources(veh):
    assert veh.engine.displacement_l == 1.497 and veh.engine.max_power_w == 54e3
    assert max(veh.engine.max_torque_nm) == pytest.approx(111.0, rel=1e-9)
    assert (veh.mg2.max_power_w, veh.mg2.max_torque_nm) == (45e3, 169.0)
    assert veh.driveline.final_drive_ratio == 3.19 and veh.driveline.mg2_reduction_ratio == 2.636
    assert (veh.battery.n_cells, veh.battery.nominal_voltage_v) == (120, 144.0)
    src = veh.sources()
    assert all(src[k].strip() for k in veh.parameters())
    # nothing calibrated on a Prius c test: the controller's sources say where it comes from
    assert all("not calibrated on a Prius c test" in v for k, v in src.items()
               if k.startswith("controller."))


def test_not_a_variant_of_the_2016_car(tmp_path):
    """The Prius c changes the axle ratio and the displacement: a variant of prius_2016 that
    tried would be refused (vehval.vehicle.variant)."""
    from vehval.errors import ConfigError

    p = tmp_path / "c.yaml"
    p.write_text("name: c\nvariant_of: prius_2016\nengine:\n  displacement_l: 1.497\n"
                 "  sources: {displacement_l: EPA list}\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"engine\.displacement_l from 1\.798 to 1\.497"):
        load_vehicle(p)


@pytest.mark.parametrize("cycle", ["udds", "us06"])
def test_invariants(veh, cycle):
    r = simulate(veh, cycle, dt=0.2, charge_balance=True)
    s = r.summary

    def sig(base):
        return np.asarray(r.test[f"{base}_simu"].values, float)

    assert s["trace_n_miss"] == 0
    assert abs(s["energy_balance_rel"]) < 1e-9  # round-off closure
    soc = sig("ess_soc")
    assert veh.battery.soc_min <= soc.min() and soc.max() <= veh.battery.soc_max
    ring = sig("mot_spd_out") / veh.driveline.mg2_reduction_ratio
    willis = ring * 78 + sig("gen_spd_out") * 30 - sig("eng_spd_out") * 108
    assert np.max(np.abs(willis)) < 1e-6  # [rad/s x teeth], every step
    v, w = sig("veh_spd"), sig("eng_spd_out")
    # the on-road log of a 2014 Prius c shows the engine off while driving at up to
    # 62 km/h; the model's engine-off driving stays within that (+5 km/h for the test)
    assert v[w == 0].max() * 3.6 <= 67.0
    assert np.all(w[(v == 0) & (r.test["veh_spd_simu"].time > 30)] == 0)
