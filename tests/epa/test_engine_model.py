"""The generic engine of a car built from specifications, against hand-computed cases."""

from __future__ import annotations

import math

import numpy as np
import pytest

from helpers.epa_lists import virtual_run
from vehval.constants import RPM_RAD_PER_S
from vehval.epa import engine_model as em
from vehval.epa import specs as sp
from vehval.epa.specs import vehicle_from_specs
from vehval.epa.specs_fit import calibrate_specs, predict_runs

VD = 2.487  # [L]
LHV = 43.0e6  # [J/kg] a round value: these cases check arithmetic, not the fuel table


def test_fmep_is_heywood_13_13():
    # 2000 rpm: 0.97 + 0.15 x 2 + 0.05 x 4 = 1.47 bar; 4000 rpm: 0.97 + 0.6 + 0.8 = 2.37 bar
    np.testing.assert_allclose(em.fmep_pa([2000.0, 4000.0]), [1.47e5, 2.37e5], rtol=1e-12)
    assert float(em.fmep_pa(2000.0, 1.2)) == pytest.approx(1.764e5, rel=1e-12)


def test_mean_effective_pressure_of_a_torque():
    # BMEP = 4 pi T / V_d: 100 N·m on 2.487 L is 1256.637 / 0.002487 = 505,282 Pa
    assert float(em.mep_pa(100.0, VD)) == pytest.approx(505282.3, rel=1e-6)
    assert float(em.torque_nm(em.mep_pa(123.4, VD), VD)) == pytest.approx(123.4, rel=1e-12)


def test_fuel_map_by_hand():
    # 2000 rpm, 100 N·m: (BMEP + FMEP) = 505,282 + 147,000 Pa over a cycle of 2.487 L at
    # 2000 / 120 cycles per second = 27,037 W; / eta 0.4 = 67,593 W; / 43 MJ/kg = 1.5719 g/s
    f = em.fuel_rate_g_per_s(np.array([2000.0]), np.array([100.0, 180.0]), np.array([200.0]),
                             VD, 0.4, 1.0, LHV)
    p_ind = (505282.3 + 147000.0) * VD * 1e-3 * 2000.0 / 120.0
    assert f[0, 0] == pytest.approx(p_ind / 0.4 / LHV * 1e3, rel=1e-6)
    assert f[0, 0] == pytest.approx(1.5719, abs=1e-4)
    # 180 of 200 N·m: share 0.9, s = (0.9 - 0.5) / 0.5 = 0.8, fuel x (1 + 0.2 x 0.8) = 1.16
    p_ind2 = (float(em.mep_pa(180.0, VD)) + 147000.0) * VD * 1e-3 * 2000.0 / 120.0
    assert f[0, 1] == pytest.approx(p_ind2 / 0.4 / LHV * 1e3 * 1.16, rel=1e-9)
    # at half load and below no extra fuel; negative torque is the fuel at zero torque
    assert em.high_load_factor(np.array([0.2, 0.5, 1.0, 1.2])).tolist() == pytest.approx(
        [1.0, 1.0, 1.2, 1.2])
    neg = em.fuel_rate_g_per_s(np.array([2000.0]), np.array([-30.0, 0.0]), np.array([200.0]),
                               VD, 0.4, 1.0, LHV)
    assert neg[0, 0] == neg[0, 1] > 0


def test_idle_control_shift_fades_to_the_fuel_cut_speed():
    shift = em.idle_control_shift(np.array([560.0, 700.0, 910.0, 1120.0, 2000.0]), 700.0,
                                  1120.0, map_at_idle_g_per_s=0.10, idle_fuel_g_per_s=0.16)
    np.testing.assert_allclose(shift, [0.06, 0.06, 0.03, 0.0, 0.0], atol=1e-12)
    # an idle leaner than the Willans line moves the map down
    assert em.idle_control_shift(np.array([700.0]), 700.0, 1120.0, 0.2, 0.15)[0] < 0


def test_vehicle_map_burns_the_measured_idle_and_locks_from_third(specs):
    plain = vehicle_from_specs(specs, 0.45, 1.0)
    veh = vehicle_from_specs(specs, 0.45, 1.0, idle_fuel_g_per_s=0.16, idle_source="measured")
    e = veh.engine
    spd, trq, fuel = np.array(e.speed_rpm), np.array(e.torque_nm), np.array(e.fuel_rate_g_per_s)
    i = int(np.flatnonzero(np.isclose(spd, sp.IDLE_SPEED_RPM))[0])
    t_acc = sp.ACCESSORY_POWER_W / (sp.IDLE_SPEED_RPM * RPM_RAD_PER_S)
    assert float(np.interp(t_acc, trq, fuel[i])) == pytest.approx(0.16, rel=1e-9)
    # from the fuel-cut speed up the map is the plain Willans map
    cut = veh.engine_control.fuel_cut_min_speed_rpm
    assert cut == pytest.approx(sp.FUEL_CUT_IDLE_RATIO * sp.IDLE_SPEED_RPM)
    up = spd >= cut - 1e-9
    np.testing.assert_allclose(fuel[up], np.array(plain.engine.fuel_rate_g_per_s)[up],
                               rtol=1e-12)
    assert veh.engine_control.idle_fuel_rate_g_per_s == 0.16
    # converter: never locked in 1st and 2nd; from 3rd at the lock-up engine speed
    lock = veh.converter.lockup_speed_mps
    assert lock[:2] == [100.0, 100.0]
    ov = veh.overall_ratios()[2]
    w_lock = lock[2] * ov / veh.driveline.wheel_radius_m / RPM_RAD_PER_S
    assert w_lock == pytest.approx(sp.LOCKUP_RPM, rel=1e-9)
    assert "knock" in veh.sources()["engine.fuel_rate_g_per_s"]


def test_calibration_stays_exact_with_the_idle_control(specs):
    """With the measured idle in the map the fuel is still affine in 1 / eta: the closed
    form recovers a known model (virtual runs carry the truth's idle fuel rate)."""
    idle = 0.17
    truth = vehicle_from_specs(specs, 0.44, 0.9, idle_fuel_g_per_s=idle)
    cal = [virtual_run(truth, "udds", "u"), virtual_run(truth, "us06", "s")]
    for r in cal:
        r.idle_fuel_kg_s = idle * 1e-3
    fit = calibrate_specs(specs, cal, dt=1.0)
    assert fit.idle_fuel_g_per_s == pytest.approx(idle)
    assert fit.indicated_efficiency == pytest.approx(0.44, rel=0.02)
    assert max(abs(e) for e in fit.errors.values()) < 0.006
    held = predict_runs(fit.model(), [virtual_run(truth, "hwfet", "h")], dt=1.0)
    assert abs(held["h"]) < 0.01
    assert math.isfinite(fit.friction_scale)
