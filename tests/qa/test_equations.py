"""Powertrain relations against hand-computed 2004 Prius cases (Table 1 parameters)."""

import numpy as np
import pytest

from vehval.equations import powertrain as pt
from vehval.equations.expr import parse_expression
from vehval.errors import ConfigError

NR, NS, FD, R = 78.0, 30.0, 4.113, 0.305


def test_willis_hand_case():
    # engine 2000 rpm, motor 3000 rpm: gen = (2000*108 - 3000*78)/30 = (216000-234000)/30 = -600 rpm
    rpm = 2 * np.pi / 60
    assert pt.willis_gen_speed(2000 * rpm, 3000 * rpm, NR, NS) == pytest.approx(-600 * rpm, rel=1e-12)
    assert pt.willis_mot_speed(2000 * rpm, -600 * rpm, NR, NS) == pytest.approx(3000 * rpm, rel=1e-12)
    assert pt.willis_eng_speed(3000 * rpm, -600 * rpm, NR, NS) == pytest.approx(2000 * rpm, rel=1e-12)


def test_willis_invariant_random():
    rng = np.random.default_rng(0)
    e, m = rng.uniform(0, 500, 100), rng.uniform(-100, 600, 100)
    g = pt.willis_gen_speed(e, m, NR, NS)
    np.testing.assert_allclose(m * NR + g * NS, e * (NR + NS), rtol=1e-12)


def test_torque_split_hand_case():
    # engine 100 N·m: ring 100*78/108 = 72.2222 N·m, sun -100*30/108 = -27.7778 N·m
    assert pt.ring_torque(100.0, NR, NS) == pytest.approx(72.2222222, rel=1e-9)
    assert pt.sun_torque(100.0, NR, NS) == pytest.approx(-27.7777778, rel=1e-9)
    # wheel torque 1000 N·m: motor = 1000/4.113 - 72.2222 = 243.1315 - 72.2222 = 170.9093
    assert pt.motor_torque(1000.0, FD, pt.ring_torque(100.0, NR, NS)) == pytest.approx(170.90928, rel=1e-6)


def test_vehicle_force_hand_case():
    # v = 20 m/s: road load 88.6 + 2.8 + 144 = 235.4 N; a = 1 m/s2: m a = 1295 N
    assert pt.road_load(20.0, 88.6, 0.14, 0.36) == pytest.approx(235.4, rel=1e-12)
    assert pt.road_load(0.0, 88.6, 0.14, 0.36, standstill_mps=0.1) == 0.0
    f_out = pt.vehicle_force_out(1295.0, 1.0, 0.0)
    assert pt.vehicle_force_in(f_out, 235.4) == pytest.approx(1530.4, rel=1e-12)
    assert pt.wheel_torque(1530.4, R) == pytest.approx(466.772, rel=1e-9)
    assert pt.vehicle_force_out(1000.0, 2.0, 0.05) == pytest.approx(2100.0)


def test_calculus_helpers():
    t = np.linspace(0, 10, 101)
    np.testing.assert_allclose(pt.deriv(t, 3 * t), 3.0, rtol=1e-12)
    assert pt.cumint(t, np.full(t.size, 2.0))[-1] == pytest.approx(20.0)
    assert pt.fuel_power(1e-3, 42.6e6) == pytest.approx(42600.0)
    assert np.isnan(pt.efficiency(1.0, 0.0, 1e-3))


def test_expression_language_is_safe_and_works():
    ex = parse_expression("where(a > 1, a * k, -a) + deriv(a)")
    t = np.arange(5.0)
    out = ex.evaluate({"a": t.copy(), "k": 2.0}, t)
    np.testing.assert_allclose(out, [1.0, 0.0, 5.0, 7.0, 9.0])
    assert ex.names == {"a", "k"}
    for bad in ("__import__('os')", "a.b", "a[0]", "lambda: 1", "open('x')", "'s'", "f(x=1)"):
        with pytest.raises(ConfigError):
            parse_expression(bad, "test")
