"""Level-3 drift of the tractive force compares like with like.

The dyno applies its *set* road-load coefficients, the calculation uses the *target* ones;
their difference (the car's losses on the rolls) and an inertia mismatch depend on speed and
acceleration, not on time, and must not read as a zero drift; a real drift still must.
"""

import numpy as np

from vehval.equations.calc import compute
from vehval.qa.findings import Kind
from vehval.qa.level3 import run_level3
from vehval.test import Signal

from .helpers import CONSTANTS, NR, NS, make_test

VEH = {"planetary": {"ring_teeth": NR, "sun_teeth": NS}}


def _force_findings(test):
    res = compute(test, VEH, "power_split", dict(CONSTANTS))
    _, found = run_level3(test, res)
    return [f for f in found if f.signal == "veh_frc_in_test" and f.kind == Kind.OFFSET]


def _with_force(test, values):
    s = test["veh_frc_in_test"]
    test.add(Signal.standard(s.name, s.time, values, source=s.source), replace_existing=True)
    return test


def test_set_vs_target_road_load_offset_is_not_a_drift():
    test = make_test(seed=41, duration=600.0)
    s, v = test["veh_frc_in_test"], test["veh_spd_test"]
    spd = v.at(s.time)
    acc = np.gradient(spd, s.time)
    # the dyno's set coefficients lower than the target by 40 N + 3 N/(m/s) + 0.05 N/(m/s)^2,
    # and an inertia setting 30 kg off: a speed- and acceleration-dependent difference only
    shifted = s.values - (40.0 + 3.0 * spd + 0.05 * spd ** 2) + 30.0 * acc
    assert _force_findings(_with_force(test, shifted)) == []


def test_real_force_drift_is_still_found_beside_the_offset():
    test = make_test(seed=42, duration=600.0)
    s, v = test["veh_frc_in_test"], test["veh_spd_test"]
    spd = v.at(s.time)
    drift = np.clip((s.time - 100) / (s.time[-1] - 100), 0, 1) * 150.0   # 150 N zero drift
    found = _force_findings(_with_force(test, s.values - (40.0 + 3.0 * spd) + drift))
    assert found and abs(found[0].numbers["drift"] - 150.0) < 40.0, [f.message for f in found]
    assert "set and target" in found[0].message
