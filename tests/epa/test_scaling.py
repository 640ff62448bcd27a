"""Component scaling (vehval.vehicle.scaling): hand-checked factors and invariants."""

from __future__ import annotations

import numpy as np
import pytest

from vehval.constants import RPM_RAD_PER_S
from vehval.vehicle import load_vehicle
from vehval.vehicle.maps import peak_brake_efficiency_of_map
from vehval.vehicle.scaling import (
    fit_loss_surface,
    loss_basis,
    machine_scale,
    scale_battery,
    scale_engine_map,
    scale_machine_map,
)


def test_machine_scale_factors_by_hand():
    # 2004 MG2 (50 kW, 6500 rpm) -> 53 kW, 17000 rpm: k_n = 2.6154, k_p = 1.06, k_t = 0.4053
    k = machine_scale(6500, 50e3, 17000, 53e3)
    assert k.speed == pytest.approx(17000 / 6500, rel=1e-12)
    assert k.loss == pytest.approx(1.06, rel=1e-12)
    assert k.torque == pytest.approx(1.06 / (17000 / 6500), rel=1e-12)
    assert 400 * k.torque == pytest.approx(162.1, abs=0.1)  # close to the published 163 N·m


def test_efficiency_kept_at_corresponding_points():
    veh = load_vehicle("prius_2004")
    m = veh.mg2
    k = machine_scale(m.max_speed_rpm, m.max_power_w, 17000, 23e3)
    spd, trq, loss = scale_machine_map(m.speed_rpm, m.torque_nm, m.loss_w, k)
    w0 = np.asarray(m.speed_rpm)[:, None] * RPM_RAD_PER_S * np.asarray(m.torque_nm)[None, :]
    w1 = np.asarray(spd)[:, None] * RPM_RAD_PER_S * np.asarray(trq)[None, :]
    l0, l1 = np.asarray(m.loss_w), np.asarray(loss)
    mask = np.abs(w0) > 1.0
    eff0 = np.abs(w0[mask]) / (np.abs(w0[mask]) + l0[mask])
    eff1 = np.abs(w1[mask]) / (np.abs(w1[mask]) + l1[mask])
    assert np.allclose(eff0, eff1, rtol=1e-12)  # round-off only


def test_engine_scaling_moves_the_peak():
    e = load_vehicle("prius_2004").engine
    lhv = e.fuel_lhv_j_per_kg
    eta0 = peak_brake_efficiency_of_map(e.speed_rpm, e.torque_nm, e.fuel_rate_g_per_s,
                                        e.max_torque_nm, lhv)[0]
    assert 0.35 < eta0 < 0.39  # DESIGN.md: about 37 % for the 2004 engine
    spd, trq, fuel, tmax = scale_engine_map(e.speed_rpm, e.torque_nm, e.fuel_rate_g_per_s,
                                            e.max_torque_nm, 1.04, 142 / 111, 0.40 / eta0)
    assert peak_brake_efficiency_of_map(spd, trq, fuel, tmax, lhv)[0] == pytest.approx(0.40,
                                                                         rel=1e-9)
    assert max(tmax) == pytest.approx(142, rel=1e-12)


def test_loss_fit_recovers_a_known_surface():
    rng = np.random.default_rng(3)
    n = rng.uniform(300, 6000, 300)
    t = rng.uniform(10, 300, 300)
    truth = np.array([2.0, 0.07, 0.5, 0.3, 4.0])
    w = n * RPM_RAD_PER_S
    loss = loss_basis(w, t) @ truth
    surf = fit_loss_surface(n, t, loss)
    assert np.allclose(surf.coef, truth, rtol=1e-6)
    assert surf.rms_w < 1e-6
    assert surf(np.array([-1000.0]), np.array([-50.0])) == pytest.approx(
        surf(np.array([1000.0]), np.array([50.0])))  # symmetric in speed and torque sign


def test_efficiency_floor_by_hand():
    """loss <= |P| (1/eta(|P|/P_rated) - 1): at 1000 rpm and 10 N·m, P = 1047.2 W, 10.47 % of
    10 kW, eta = 0.8 + 0.1 x 0.1047 = 0.81047, so at most 244.89 W; no loss at zero power."""
    from vehval.vehicle.scaling import efficiency_floor_losses

    spd, trq = [0.0, 1000.0], [-10.0, 0.0, 10.0]
    loss = np.array([[50.0, 50.0, 50.0], [500.0, 50.0, 100.0]])
    out = efficiency_floor_losses(spd, trq, loss, 10e3, [0.0, 1.0], [0.8, 0.9])
    p = 1000 * np.pi / 30 * 10
    cap = p * (1 / (0.8 + 0.1 * p / 10e3) - 1)
    assert cap == pytest.approx(244.89, abs=0.01)
    assert out[1, 0] == pytest.approx(cap, rel=1e-12)  # 500 W capped (generating side too)
    assert out[1, 2] == 100.0  # already below the cap: kept
    assert np.all(out[0] == 0.0) and out[1, 1] == 0.0  # standstill and zero torque


def test_battery_scaling_by_hand():
    # 2004 pack (168 NiMH cells, 201.6 V, 6.5 Ah) -> the gen-4 Li-ion pack (56 cells,
    # 207.2 V, 3.6 Ah): k_v = 1.02778, k_c = 0.55385
    ref = load_vehicle("prius_2004").battery
    li = scale_battery(ref, n_cells=56, n_modules=2, capacity_ah=3.6, nominal_voltage_v=207.2,
                       chemistry="li_ion", ref_name="the 2004 pack")
    k_v, k_c = 207.2 / 201.6, 3.6 / 6.5
    i50 = ref.soc.index(0.5)
    assert li.ocv_v[i50] == pytest.approx(215.35 * k_v, rel=1e-12)  # 221.33 V
    assert li.resistance_discharge_ohm[i50] == pytest.approx(0.35 * k_v / k_c, rel=1e-12)
    assert li.resistance_discharge_ohm[i50] == pytest.approx(0.6495, abs=1e-4)
    assert max(li.discharge_power_limit_w) == pytest.approx(21000 * k_v * k_c, rel=1e-12)
    assert li.chemistry == "li_ion" and li.soc == ref.soc and li.soc_max == ref.soc_max
    assert "k_v / k_c" in li.sources["resistance_discharge_ohm"]
    # the invariant behind it: at the same C-rate the loss fraction I R / V is the same
    for k in range(len(ref.soc)):
        f_ref = (2.0 * ref.capacity_ah) * ref.resistance_discharge_ohm[k] / ref.ocv_v[k]
        f_new = (2.0 * li.capacity_ah) * li.resistance_discharge_ohm[k] / li.ocv_v[k]
        assert f_new == pytest.approx(f_ref, rel=1e-12)
    # a given rating: the limit curves keep their shape
    rated = scale_battery(ref, n_cells=56, n_modules=2, capacity_ah=3.6,
                          nominal_voltage_v=207.2, chemistry="li_ion", power_limit_w=27e3)
    assert max(rated.charge_power_limit_w) == pytest.approx(27e3, rel=1e-12)
    assert np.allclose(np.asarray(rated.discharge_power_limit_w) / 27e3,
                       np.asarray(ref.discharge_power_limit_w) / 21e3, rtol=1e-12)


def test_battery_scaling_identity_and_refusals():
    ref = load_vehicle("prius_2004").battery
    same = scale_battery(ref, n_cells=168, n_modules=28, capacity_ah=6.5)
    for key in ("ocv_v", "resistance_discharge_ohm", "resistance_charge_ohm",
                "discharge_power_limit_w", "charge_power_limit_w"):
        assert getattr(same, key) == pytest.approx(getattr(ref, key), rel=1e-12)
    assert same.nominal_voltage_v == pytest.approx(201.6, rel=1e-12)
    # same chemistry, twice the cells: voltage from the reference's volts per cell
    double = scale_battery(ref, n_cells=336, n_modules=56, capacity_ah=6.5)
    assert double.nominal_voltage_v == pytest.approx(403.2, rel=1e-12)
    assert double.resistance_charge_ohm[0] == pytest.approx(2 * ref.resistance_charge_ohm[0])
    with pytest.raises(ValueError, match="nominal_voltage_v"):
        scale_battery(ref, n_cells=56, n_modules=2, capacity_ah=3.6, chemistry="li_ion")
    with pytest.raises(ValueError, match="multiple of 'n_modules'"):
        scale_battery(ref, n_cells=57, n_modules=2, capacity_ah=3.6)


def test_scaled_li_ion_pack_keeps_the_invariants():
    """The 2004 Prius with a scaled Li-ion pack: energy closes, the SOC window and the
    pack's power limits hold, the trace is followed."""
    from vehval.sim.simulate import simulate

    veh = load_vehicle("prius_2004")
    li = scale_battery(veh.battery, n_cells=56, n_modules=2, capacity_ah=3.6,
                       nominal_voltage_v=207.2, chemistry="li_ion")
    res = simulate(veh.model_copy(update={"battery": li}), "udds", dt=0.2)
    s = res.summary
    assert abs(s["energy_balance_rel"]) < 1e-9  # round-off closure of the kernel
    soc = res.test["ess_soc_simu"].values
    assert li.soc_min <= soc.min() and soc.max() <= li.soc_max
    p = res.test["ess_pwr_simu"].values
    assert p.max() <= max(li.discharge_power_limit_w) * 1.06  # the kernel's mid-step margin
    assert s["trace_n_miss"] == 0
