"""Hand-computed cases for the component physics (pure functions)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vehval.sim.components.battery import current_from_power, terminal_voltage
from vehval.sim.components.body import equivalent_mass, road_load
from vehval.sim.components.boost import battery_side_power, output_voltage
from vehval.sim.components.driveline import ring_speed_from_vehicle, wheel_force_from_ring_torque
from vehval.sim.components.electric_machine import electrical_power, torque_for_power, torque_limit
from vehval.sim.components.engine import fuel_rate
from vehval.sim.components.planetary import (
    ring_torque_from_engine,
    sun_speed,
    sun_torque_from_engine,
    willis_residual,
)
from vehval.sim.maps import interp1, interp2

RPM = math.pi / 30


def test_road_load_hand_computed():
    # F = A + B v + C v^2 at 20 m/s with Table 1: 88.6 + 0.14*20 + 0.36*400 = 235.4 N
    assert road_load(20.0, 88.6, 0.14, 0.36) == pytest.approx(235.4, rel=1e-12)
    assert road_load(0.0, 88.6, 0.14, 0.36) == 0.0  # static: no force at standstill


def test_equivalent_mass():
    # 1295 kg + 1.9 kg m^2 / 0.305^2 m^2 = 1295 + 20.42 kg
    assert equivalent_mass(1295, 1.9, 0.305) == pytest.approx(1295 + 1.9 / 0.305 ** 2)


def test_willis_hand_computed():
    # ring 300 rad/s, carrier 200 rad/s, 30/78: sun = (200*108 - 300*78)/30 = -60 rad/s
    ws = sun_speed(200.0, 300.0, 30, 78)
    assert ws == pytest.approx(-60.0, abs=1e-12)
    assert willis_residual(300.0, ws, 200.0, 30, 78) == pytest.approx(0.0, abs=1e-9)
    # eq. (2): T_ring = T_eng * 78/108; the sun reacts -T_eng * 30/108
    assert ring_torque_from_engine(108.0, 30, 78) == pytest.approx(78.0)
    assert sun_torque_from_engine(108.0, 30, 78) == pytest.approx(-30.0)


def test_battery_current_from_power_hand_computed():
    # P = (Voc - I R) I: 10 kW at Voc = 220 V, R = 0.35 ohm -> I = (220 - sqrt(220^2 - 4*0.35*1e4)) / 0.7
    i = current_from_power(10_000.0, 220.0, 0.35)
    assert i == pytest.approx((220 - math.sqrt(220 ** 2 - 14_000)) / 0.7, rel=1e-12)
    assert i == pytest.approx(49.3, abs=0.05)
    assert terminal_voltage(220.0, 0.35, i) * i == pytest.approx(10_000.0, rel=1e-12)
    # charging: negative power gives negative current, terminal voltage above OCV
    ic = current_from_power(-10_000.0, 220.0, 0.35)
    assert ic < 0 and terminal_voltage(220.0, 0.35, ic) > 220.0


def test_machine_limits_and_power():
    # MG2: 400 N·m up to 50 kW / 400 N·m = 125 rad/s (1194 rpm), then 50 kW / w
    assert torque_limit(400.0, 50_000.0, 100.0) == 400.0
    assert torque_limit(400.0, 50_000.0, 2000 * RPM) == pytest.approx(50_000 / (2000 * RPM))
    spd = np.array([0.0, 100.0, 200.0])
    trq = np.array([-100.0, 0.0, 100.0])
    loss = np.array([[50.0, 0.0, 50.0], [300.0, 0.0, 300.0], [600.0, 0.0, 600.0]])
    # motoring: electrical = mechanical + loss; generating: electrical = mechanical + loss (less negative)
    assert electrical_power(spd, trq, loss, 100.0, 100.0) == pytest.approx(10_000 + 300)
    assert electrical_power(spd, trq, loss, 100.0, -100.0) == pytest.approx(-10_000 + 300)
    # torque_for_power inverts electrical_power (bisection, 30 halvings of 200 N·m)
    t = torque_for_power(spd, trq, loss, 150.0, 5_000.0, -100.0, 100.0)
    assert electrical_power(spd, trq, loss, 150.0, t) == pytest.approx(5_000.0, abs=1e-3)


def test_interpolation_hand_computed():
    bp = np.array([0.0, 1.0, 3.0])
    tab = np.array([0.0, 10.0, 30.0])
    assert interp1(bp, tab, 2.0) == pytest.approx(20.0)
    assert interp1(bp, tab, 5.0) == 30.0  # clamped, never extrapolated
    z = np.array([[0.0, 1.0], [2.0, 3.0]])
    assert interp2(np.array([0.0, 1.0]), np.array([0.0, 1.0]), z, 0.5, 0.5) == pytest.approx(1.5)


def test_fd_boost_and_engine(prius):
    # ring speed: 10 m/s * 4.113 / 0.305 m
    assert ring_speed_from_vehicle(10.0, 4.113, 0.305) == pytest.approx(134.85, abs=0.01)
    # driving loses on the way out, regen loses on the way in
    assert wheel_force_from_ring_torque(100.0, 4.113, 0.305, 0.97) == pytest.approx(
        100 * 4.113 / 0.305 * 0.97)
    assert wheel_force_from_ring_torque(-100.0, 4.113, 0.305, 0.97) == pytest.approx(
        -100 * 4.113 / 0.305 / 0.97)
    assert battery_side_power(1000.0, 0.97) == pytest.approx(1000 / 0.97)
    assert battery_side_power(-1000.0, 0.97) == pytest.approx(-970.0)
    assert output_voltage(210.0, 0.0, 201.6, 500.0) == 210.0
    assert output_voltage(210.0, 2.0, 201.6, 500.0) == 500.0
    a = prius.engine.arrays()
    # min BSFC of the scaled map inside the full-load curve is about 225 g/kWh (public fact)
    w = 3000 * RPM
    tq = 95.0
    bsfc = fuel_rate(a["spd"], a["trq"], a["fuel"], w, tq) * 1e3 / (w * tq / 1e3) * 3600
    assert 215 < bsfc < 245


def test_best_line_within_full_load(prius):
    p, w, t = prius.best_line
    a = prius.engine.arrays()
    assert np.all(np.diff(w) >= 0)  # speed never falls with rising power
    assert np.all(t <= np.interp(w, a["spd"], a["tmax"]) + 1e-6)
    assert w.max() <= prius.engine.max_speed_rpm * RPM + 1e-9
    assert p[-1] == pytest.approx(prius.engine.max_power_w)
