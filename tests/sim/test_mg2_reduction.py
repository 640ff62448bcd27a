"""MG2 reduction gear (power-split cars after 2004): an equivalent machine gives equal results.

A machine behind a reduction ratio r is equivalent, at the ring gear, to a machine with
speeds divided by r, torques multiplied by r, the same losses and the inertia times r^2.
Simulating the 2004 car with such a pair (r = 2.636 with the MG2 map re-scaled to its
shaft) must reproduce the direct-drive run: same fuel, same SOC, same ring-side torque.
"""

from __future__ import annotations

import numpy as np
import pytest

from vehval.errors import ConfigError
from vehval.sim.simulate import simulate

R = 2.636  # MG2 reduction of the 2010 Prius, used here only as a non-trivial ratio


def _behind_reduction(veh, r):
    m = veh.mg2
    mg2 = m.model_copy(update={
        "speed_rpm": [x * r for x in m.speed_rpm], "torque_nm": [x / r for x in m.torque_nm],
        "max_torque_nm": m.max_torque_nm / r, "max_speed_rpm": m.max_speed_rpm * r,
        "inertia_kg_m2": m.inertia_kg_m2 / (r * r)})
    dl = veh.driveline.model_copy(update={"mg2_reduction_ratio": r})
    return veh.model_copy(update={"mg2": mg2, "driveline": dl})


def test_default_ratio_is_one_and_needs_no_source(prius):
    assert prius.driveline.mg2_reduction_ratio == 1.0
    data = prius.driveline.model_dump(exclude={"mg2_reduction_ratio"})
    data["sources"].pop("mg2_reduction_ratio")
    assert type(prius.driveline).model_validate(data).mg2_reduction_ratio == 1.0


def test_equivalent_machine_behind_reduction_gives_same_run(prius):
    a = simulate(prius, "ece15", dt=0.5)
    b = simulate(_behind_reduction(prius, R), "ece15", dt=0.5)
    # rtol 1e-9: the two runs differ only by floating-point rounding of r and 1/r
    for key in ("fuel_mass_kg", "soc_final", "mot_loss_j", "brake_energy_j"):
        assert b.summary[key] == pytest.approx(a.summary[key], rel=1e-9, abs=1e-9)
    np.testing.assert_allclose(b.test["mot_spd_out_simu"].values,
                               R * a.test["mot_spd_out_simu"].values, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(R * b.test["mot_trq_out_simu"].values,
                               a.test["mot_trq_out_simu"].values, rtol=1e-9, atol=1e-7)


def test_override_and_bad_ratio(prius):
    v = prius.with_overrides({"driveline.mg2_reduction_ratio": 2.0})
    assert v.driveline.mg2_reduction_ratio == 2.0
    with pytest.raises(ConfigError, match="mg2_reduction_ratio"):
        prius.with_overrides({"driveline.mg2_reduction_ratio": -1.0})
